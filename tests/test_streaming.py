"""Issue 17: verify streams a recording (chunked reading, compiled reference, fast-engine replay)
and says exactly what the whole-recording path says; the streaming readers accept a file only
when read_table reads the same numbers from it, and decline (never drop rows) otherwise."""
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.golden_models import GOLDEN, golden_block, golden_twin_csv
from thermoplc.base.errors import UserError
from thermoplc.base import compiled as kernels
from thermoplc.recordings import chunks
from thermoplc.models.modelfile import load_model
from thermoplc.recordings.chunks import CannotStream, stream_columns
from thermoplc.recordings.table import read_table
from thermoplc.verifier.replays import stream
from thermoplc.verifier.engines.native import native_or_reason
from thermoplc.verifier.reading.parser import parse_text
from thermoplc.verifier.replays.replay import verify_against_model

pytestmark = pytest.mark.skipif(kernels.numba is None, reason="numba not installed")


@pytest.fixture(autouse=True)
def stream_short_files(monkeypatch):
    """These recordings are short, which verify reads whole (stream.WHOLE_BELOW_BYTES): here they are streamed."""
    monkeypatch.setattr(stream, "WHOLE_BELOW_BYTES", 0)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    folder = tmp_path_factory.mktemp("stream")
    path = golden_twin_csv(folder)
    table = read_table(path)
    np.savez(folder / "twin.npz", **table.columns)
    return folder, path, table


def _without_timing(text: str) -> str:
    return re.sub(r"replay: .*", "replay: ...", text)


def _fast_engine_here() -> bool:
    return native_or_reason(parse_text(golden_block("mlr", "tia").read_text(), "b.scl"))[0] is not None


@pytest.mark.parametrize("kind,source", [(kind, source) for kind in ("kalman", "mlr") for source in ("csv", "npz", "parquet")]
                         + [(kind, "csv") for kind in ("gm0n", "gm1n", "piecewise", "bpnn", "bayes", "dlag", "lumped")])
def test_streamed_verify_reports_what_the_whole_recording_path_reports(kind, source, recording, monkeypatch):
    if not _fast_engine_here():
        pytest.skip("no C compiler: nothing is streamed")
    folder, csv_path, table = recording
    data = {"csv": csv_path, "npz": folder / "twin.npz", "parquet": folder / "twin.parquet"}[source]
    if source == "parquet":
        pa = pytest.importorskip("pyarrow")
        import pyarrow.parquet as pq
        pq.write_table(pa.table(table.columns), data)
    monkeypatch.setattr(chunks, "STREAM_ROWS", 1000)  # chunk boundaries inside the data
    monkeypatch.setattr(chunks, "STREAM_BYTES", 50_000)
    block, model_path = str(golden_block(kind, "tia")), str(GOLDEN / f"{kind}.json")
    model = load_model(model_path)
    streamed, route, seconds = stream.verify_file_against_model(block, model, model_path, str(data))
    assert route == "streamed"
    assert seconds["rows"] == table.rows
    whole = verify_against_model(block, model, model_path, read_table(data, model.time_column))
    assert streamed.ok and whole.ok
    assert _without_timing(streamed.text()) == _without_timing(whole.text())


def test_a_mismatch_is_reported_by_the_whole_recording_path(recording, tmp_path):
    """A block that differs from its model: the stream gives up and the usual report names the cycle."""
    if not _fast_engine_here():
        pytest.skip("no C compiler: nothing is streamed")
    _, csv_path, table = recording
    model_path = str(GOLDEN / "kalman.json")
    model = load_model(model_path)
    text = golden_block("kalman", "tia").read_text()
    name = next(m.group(1) for m in re.finditer(r"(c_beta_1)\s*:\s*Real\s*:=\s*([^;]+);", text))
    tampered = re.sub(r"(c_beta_1\s*:\s*Real\s*:=\s*)([^;]+);", lambda m: m.group(1) + "1.5;", text, count=1)
    assert tampered != text, name
    block = tmp_path / "kalman.scl"
    block.write_text(tampered)
    streamed, route, _ = stream.verify_file_against_model(str(block), model, model_path, str(csv_path))
    assert route.startswith("whole recording")
    whole = verify_against_model(str(block), model, model_path, read_table(csv_path, model.time_column))
    assert not streamed.ok and streamed.mismatch is not None
    assert _without_timing(streamed.text()) == _without_timing(whole.text())


def _same_as_read_table(path, names):
    """stream_columns gives exactly read_table's numbers, or declines; read_table decides errors."""
    try:
        careful = read_table(path, None)
    except UserError:
        careful = None
    try:
        chunks = list(stream_columns(path, names))
    except CannotStream:
        return "declined"
    assert careful is not None, "the stream accepted a file read_table refuses"
    for name in names:
        got = np.concatenate([c.columns[name] for c in chunks])
        want = careful.columns[name]
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64)), name
    assert [c.start for c in chunks] == list(np.cumsum([0] + [c.rows for c in chunks])[:-1])
    return "streamed"


ODD_FILES = [
    b"a,b\n1,2\n3,4\n", b"a,b\r\n1,2\r\n3,4\r\n", b"a,b\n1,2\n3,4", b"a,b\n1,2\n3,4\n\n\n", b"a,b\n1,2\n\n3,4\n",
    b"a,b\n1,2\n,\n3,4\n", b"a,b\n1,nan\n", b"a,b\n1,inf\n", b"a,b\n1,1e400\n", b"a,b\n\"1\",2\n", b"a,b\n1,2\r3,4\n",
    b"a;b\n1,5;2\n", b"a,b\n 1 , 2 \n", b"a,b\n+1,-2\n", b"a,b\n1.,.5\n", b"a,b\n1_0,2\n", b"a,b\n0x10,2\n",
    b"\xef\xbb\xbfa,b\n1,2\n", b"a,b\n1,2,3\n", b"a,b\n1\n", b"a,b\n", b"a,a\n1,2\n", b"a,b\n1,\xff\n",
    b"a,b\n1e5,-0\n", b"a,b\nNaN,1\n", b"a,b\n1,2 \n", b"a,b\n\t1,2\n", b"# c\na,b\n1,2\n", b"a,b\n1,\"2\n3\",4\n",
    b"a\n\"1\n2\"\n3\n", b"a\n1\r\n2\n",
]


@pytest.mark.parametrize("content", ODD_FILES)
def test_stream_reader_reads_what_read_table_reads_or_declines(content, tmp_path):
    path = tmp_path / "odd.csv"
    path.write_bytes(content)
    _same_as_read_table(path, ["a"])


CELLS = st.sampled_from(["1", "-2.5", "1e3", "1E-3", ".5", "5.", "+3", " 4", "4 ", "", "nan", "inf", "x", "1,5",
                         '"7"', "0", "-0", "3.4028235e38", "1e39", "\t2"])


@given(st.lists(st.tuples(CELLS, CELLS), min_size=1, max_size=6), st.sampled_from(["\n", "\r\n", "\r"]),
       st.booleans())
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_stream_reader_never_differs_from_read_table(tmp_path, rows, newline, blank):
    lines = ["a,b"] + [f"{x},{y}" for x, y in rows]
    if blank:
        lines.insert(2, "")
    path = tmp_path / "f.csv"
    path.write_bytes(newline.join(lines).encode() + newline.encode())
    _same_as_read_table(path, ["a", "b"])


def test_npz_streamed_in_chunks_equals_np_load(tmp_path, monkeypatch):
    rng = np.random.default_rng(1)
    columns = {"t": np.arange(2500.0), "x": rng.normal(size=2500).astype(np.float32), "n": np.arange(2500)}
    for save in (np.savez, np.savez_compressed):
        save(tmp_path / "d.npz", **columns)
        chunks = list(stream_columns(tmp_path / "d.npz", ["x", "n"], rows_per_chunk=700))
        assert [c.rows for c in chunks] == [700, 700, 700, 400]
        for name in ("x", "n"):
            assert np.array_equal(np.concatenate([c.columns[name] for c in chunks]), columns[name].astype(np.float64))
    np.savez(tmp_path / "bad.npz", t=np.arange(3.0), x=np.array([1.0, np.nan, 2.0]))
    with pytest.raises(CannotStream):
        list(stream_columns(tmp_path / "bad.npz", ["t"]))  # a NaN in any column: read_table refuses the file


def test_parquet_reads_like_npz(tmp_path):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq
    pq.write_table(pa.table({"time_s": np.arange(5.0), "x": np.arange(5, dtype=np.int32)}), tmp_path / "d.parquet")
    table = read_table(tmp_path / "d.parquet")
    assert table.rows == 5 and table.columns["x"].dtype == np.float64
    pq.write_table(pa.table({"time_s": np.arange(3.0), "x": ["a", "b", "c"]}), tmp_path / "s.parquet")
    with pytest.raises(UserError, match="column 'x' holds string, expected numbers"):
        read_table(tmp_path / "s.parquet")
    pq.write_table(pa.table({"time_s": [0.0, 1.0, None]}), tmp_path / "n.parquet")
    with pytest.raises(UserError, match="column 'time_s' row 3: expected a finite number, found an empty cell"):
        read_table(tmp_path / "n.parquet")


@pytest.mark.parametrize("block_bytes", range(3, 40, 2))
def test_a_blank_line_at_any_block_boundary_is_never_dropped(block_bytes, tmp_path, monkeypatch):
    monkeypatch.setattr(chunks, "STREAM_BYTES", block_bytes)
    for content in (b"a,b\n1,2\n3,4\n\n5,6\n7,8\n", b"a,b\n1,2\n3,4\n5,6\n7,8\n\n \n", b"a,b\r\n1,2\r\n\r\n3,4\r\n"):
        path = tmp_path / "b.csv"
        path.write_bytes(content)
        outcome = _same_as_read_table(path, ["a", "b"])
        assert outcome == ("declined" if b"\n\n5" in content or b"\n\r\n3" in content else "streamed"), content
