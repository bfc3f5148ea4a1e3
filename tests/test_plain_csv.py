"""Issue 40: the plain-number CSV parser (recordings/plain_csv/) reads every number with the bits pyarrow and
Python's float() give it, declines anything that is not a plain number, and the streamed reader gives the same
columns through it as through pyarrow and read_table."""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.test_streaming import ODD_FILES, _same_as_read_table
from thermoplc.base import compiled as kernels
from thermoplc.recordings import chunks
from thermoplc.recordings.chunks import CannotStream, stream_columns
from thermoplc.recordings.table import read_table

pytestmark = pytest.mark.skipif(kernels.numba is None, reason="numba not installed")
plain_csv = pytest.importorskip("thermoplc.recordings.plain_csv") if kernels.numba is not None else None


def _block(lines: list[str]) -> tuple[bytes, int]:
    text = "".join(line + "\n" for line in lines).encode()
    return text + bytes(plain_csv.PADDING), len(text)


def _parsed(lines, keep, delimiter=",", point=".", threads=2):
    data, end = _block(lines)
    arrays = plain_csv.parse_block(data, end, keep, delimiter, point, threads)
    return None if arrays is None else np.concatenate(arrays, axis=1)


def _bits(values) -> np.ndarray:
    return np.asarray(values, np.float64).view(np.uint64)


DIGITS = st.text("0123456789", min_size=1, max_size=21)
PLAIN = st.builds(lambda sign, whole, fraction: sign + whole + ("." + fraction if fraction else ""),
                  st.sampled_from(["", "-"]), DIGITS, st.one_of(st.just(""), DIGITS))


def _exact_fast_path(cell: str) -> bool:
    """Cells the parser must take: at most 19 digits, an integer of them <= 2**53, at most 22 decimals."""
    digits = cell.lstrip("-").replace(".", "")
    decimals = len(cell.split(".")[1]) if "." in cell else 0
    return len(digits) <= 19 and int(digits) <= 2 ** 53 and decimals <= 22


@given(st.lists(st.lists(PLAIN, min_size=3, max_size=3), min_size=1, max_size=40), st.integers(1, 4))
@settings(max_examples=300, deadline=None)
def test_every_plain_number_has_the_bits_of_float_and_pyarrow(rows, threads):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.csv as pacsv
    got = _parsed([",".join(row) for row in rows], [True] * 3, threads=threads)
    if not all(_exact_fast_path(cell) for row in rows for cell in row):
        assert got is None or np.array_equal(_bits(got), _bits([[float(r[c]) for r in rows] for c in range(3)]))
        return
    assert got is not None, "a plain file was declined"
    want = np.array([[float(row[c]) for row in rows] for c in range(3)])
    assert np.array_equal(_bits(got), _bits(want))
    text = "".join(",".join(row) + "\n" for row in rows).encode()
    arrow = pacsv.read_csv(pa.py_buffer(text), read_options=pacsv.ReadOptions(column_names=["a", "b", "c"]),
                           convert_options=pacsv.ConvertOptions(column_types={n: pa.float64() for n in "abc"}))
    assert np.array_equal(_bits(got), _bits([arrow.column(n).to_numpy() for n in "abc"]))


NOT_PLAIN = ["", "1e5", "1E5", "+1", " 1", "1 ", "1.", ".5", "-", "--1", "nan", "inf", '"1"', "1_0", "0x1", "1,5",
             "1.2.3", "١", "1\r", "12345678901234567890", "9007199254740993", "0." + "0" * 22 + "1"]


@given(st.lists(st.lists(PLAIN.filter(_exact_fast_path), min_size=2, max_size=2), min_size=1, max_size=20),
       st.sampled_from(NOT_PLAIN), st.data())
@settings(max_examples=200, deadline=None)
def test_one_cell_that_is_not_plain_declines_the_block(rows, bad, data):
    row = data.draw(st.integers(0, len(rows) - 1))
    column = data.draw(st.integers(0, 1))
    rows[row][column] = bad
    keep = [True, data.draw(st.booleans())]  # a column that is not kept is still checked
    assert _parsed([",".join(r) for r in rows], keep) is None


@pytest.mark.parametrize("lines", [["1,2", "3"], ["1,2", "3,4,5"], ["1,2", ""], ["1,2", ",", "3,4"]])
def test_a_line_of_another_shape_declines_the_block(lines):
    assert _parsed(lines, [True, True]) is None


def test_kept_columns_decimal_comma_and_many_short_rows():
    assert np.array_equal(_parsed(["1,5;-2;3", "0,25;4;5"], [True, False, True], delimiter=";", point=","),
                          [[1.5, 0.25], [3.0, 5.0]])
    rows = [f"{i % 10},{i % 7}" for i in range(5000)]  # 4 bytes a row: more rows than one array holds
    data, end = _block(rows)
    arrays = plain_csv.parse_block(data, end, [True, True], ",", ".", 1)
    assert len(arrays) > 1
    assert np.array_equal(np.concatenate(arrays, axis=1), [[i % 10 for i in range(5000)], [i % 7 for i in range(5000)]])
    assert np.signbit(_parsed(["-0,0"], [True, True])[0, 0])


def test_a_block_without_room_after_it_is_refused():
    with pytest.raises(ValueError, match="PADDING"):
        plain_csv.parse_block(b"1,2\n", 4, [True, True], ",", ".", 1)


@pytest.fixture
def plain_route(monkeypatch):
    """Every block offered to the plain parser, counted."""
    calls = []
    parse = plain_csv.parse_block

    def counted(*args):
        result = parse(*args)
        calls.append(result is not None)
        return result

    monkeypatch.setattr(chunks, "PLAIN_PARSE_BYTES", 0)
    monkeypatch.setattr(plain_csv, "parse_block", counted)
    return calls


@pytest.mark.parametrize("content", ODD_FILES)
def test_odd_files_read_as_read_table_reads_them_on_the_plain_route(content, tmp_path, plain_route):
    path = tmp_path / "odd.csv"
    path.write_bytes(content)
    _same_as_read_table(path, ["a"])


@pytest.mark.parametrize("block_bytes", [7, 64, 1000])
def test_a_recording_streams_the_same_through_either_parser(block_bytes, tmp_path, monkeypatch, plain_route):
    rng = np.random.default_rng(5)
    rows = 3000
    lines = ["time_s,x,y,z"] + [f"{t * 0.5!r},{x:.6f},{y:.3f},{z:.12f}" for t, x, y, z in
                                zip(range(rows), rng.normal(20, 3, rows), rng.normal(0, 1e5, rows), rng.normal(size=rows))]
    lines[2000] = lines[2000].replace(",", ",2e1*", 1).split("*")[0] + "," + lines[2000].split(",", 2)[2]  # not plain
    path = tmp_path / "r.csv"
    path.write_text("\n".join(lines) + "\n")
    monkeypatch.setattr(chunks, "STREAM_BYTES", block_bytes)
    assert _same_as_read_table(path, ["time_s", "x", "y"]) == "streamed"
    assert any(plain_route) and not all(plain_route), plain_route  # both routes ran: plain blocks and the 2e1 one
    plain = list(stream_columns(path, ["x", "y", "time_s"]))
    monkeypatch.setattr(chunks, "PLAIN_PARSE_BYTES", 1 << 60)
    arrow = list(stream_columns(path, ["x", "y", "time_s"]))
    for name in ("x", "y", "time_s"):
        assert np.array_equal(_bits(np.concatenate([c.columns[name] for c in plain])),
                              _bits(np.concatenate([c.columns[name] for c in arrow])))
        assert np.array_equal(_bits(np.concatenate([c.columns[name] for c in plain])), _bits(read_table(path).columns[name]))


def test_a_bad_cell_in_a_column_verify_does_not_need_still_declines(tmp_path, plain_route):
    path = tmp_path / "r.csv"
    path.write_text("time_s,x,unused\n" + "".join(f"{t},{t * 2},{t * 3}\n" for t in range(100)) + "100,200,oops\n")
    with pytest.raises(CannotStream):
        list(stream_columns(path, ["time_s", "x"]))
    assert plain_route and not any(plain_route)


def test_verify_on_the_plain_route_is_bit_exact_and_a_tampered_block_is_not(tmp_path, monkeypatch, plain_route, capsys):
    """The command a user types, on a recording the plain parser reads block by block."""
    import re

    from tests.golden_models import GOLDEN, golden_block, golden_twin_csv
    from thermoplc.cli import main
    from thermoplc.verifier.replays import stream

    from tests.cli_runner import routes_taken
    monkeypatch.setattr(stream, "WHOLE_BELOW_BYTES", 0)
    monkeypatch.setattr(chunks, "STREAM_BYTES", 20_000)
    taken = routes_taken(monkeypatch)
    data = golden_twin_csv(tmp_path)
    block, model = golden_block("kalman", "tia"), GOLDEN / "kalman.json"
    assert main(["verify", str(block), "--model", str(model), "--data", str(data)]) == 0
    out = capsys.readouterr().out
    assert "bit-exact" in out and "NOT bit-exact" not in out
    assert taken == ["streamed"] and len(plain_route) > 10 and all(plain_route)
    tampered = tmp_path / "tampered.scl"
    tampered.write_text(re.sub(r"(c_beta_1\s*:\s*Real\s*:=\s*)([^;]+);", r"\g<1>1.5;", block.read_text(), count=1))
    assert main(["verify", str(tampered), "--model", str(model), "--data", str(data)]) != 0
    assert "NOT bit-exact" in capsys.readouterr().out


@pytest.mark.parametrize("delimiter,point", [(",", ","), ("1", "."), (",", "-"), ("\n", ".")])
def test_separators_that_a_number_could_contain_decline(delimiter, point):
    data, end = _block([f"1{delimiter}2"])
    assert plain_csv.parse_block(data, end, [True, True], delimiter, point, 1) is None


@pytest.mark.parametrize("plain", [True, False])
@pytest.mark.parametrize("block_bytes", [5, 9, 1 << 20])
def test_a_byte_order_mark_opening_a_data_line_is_never_skipped(plain, block_bytes, tmp_path, monkeypatch):
    """pyarrow skips a byte-order mark at the start of a buffer, and each block starts one: read_table refuses."""
    monkeypatch.setattr(chunks, "STREAM_BYTES", block_bytes)
    monkeypatch.setattr(chunks, "PLAIN_PARSE_BYTES", 0 if plain else 1 << 60)
    for content in (b"t,a\n\xef\xbb\xbf1,2\n3,4\n", b"t,a\n1,2\n\xef\xbb\xbf3,4\n"):
        path = tmp_path / "bom.csv"
        path.write_bytes(content)
        assert _same_as_read_table(path, ["t", "a"]) == "declined"


def test_a_numba_that_cannot_be_imported_leaves_the_blocks_to_pyarrow(tmp_path, monkeypatch, plain_route, capfd):
    """numba found but broken (say, a numpy too new for it): no thread tracebacks, the stream still reads."""
    import sys
    monkeypatch.setitem(sys.modules, "thermoplc.recordings.plain_csv.kernels", None)  # importing it raises ImportError
    plain_csv.available.cache_clear()
    try:
        path = tmp_path / "r.csv"
        path.write_text("t,x\n" + "".join(f"{t},{t / 4}\n" for t in range(2000)))
        monkeypatch.setattr(chunks, "STREAM_BYTES", 1000)
        assert _same_as_read_table(path, ["t", "x"]) == "streamed"
        assert plain_route == []
        assert "Traceback" not in capfd.readouterr().err
    finally:
        plain_csv.available.cache_clear()
