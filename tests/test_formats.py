"""Column file formats are records (recordings/formats/): reading whole, streaming, a folder's runs and the help
take a format from its record, so a new format is a module of that folder and nothing else."""
import json
from pathlib import Path

import numpy as np
import pytest

from thermoplc.base.errors import UserError
from thermoplc.recordings import formats
from thermoplc.recordings.campaign import recording_paths
from thermoplc.recordings.chunks import stream_columns
from thermoplc.recordings.formats import InputFormat, described, format_of, registry, suffixes
from thermoplc.recordings.table import read_table


def test_the_records_are_the_formats_every_reader_knows():
    assert list(registry()) == ["npz", "parquet"]
    assert suffixes() == (".csv", ".npz", ".parquet")
    assert described() == "CSV, .npz or Parquet"
    assert format_of("run.PARQUET").name == "parquet" and format_of("s3://b/run.npz?versionId=3").name == "npz"
    assert format_of("run.csv") is None and format_of("run.txt") is None  # read as CSV text


def _json_columns(path: str, sparse: frozenset, gaps: bool) -> dict:
    columns = {name: np.asarray(values, np.float64) for name, values in json.loads(Path(path).read_text()).items()}
    for name, values in columns.items():
        if not np.isfinite(values).all():
            raise UserError(f"{path}: column {name!r}: expected finite numbers")
    return columns


def _json_chunks(path: str, rows: int):
    columns = _json_columns(path, frozenset(), False)
    total = len(next(iter(columns.values())))
    for start in range(0, total, rows):
        yield {name: values[start:start + rows] for name, values in columns.items()}


@pytest.fixture
def json_format(monkeypatch):
    """A format declared by its record alone: columns as a JSON object, written for this test."""
    known = registry()
    record = InputFormat(name="json", suffix=".json", title="JSON columns", rank=9, columns=_json_columns,
                         chunks=_json_chunks)
    monkeypatch.setattr(formats, "registry", lambda: {**known, "json": record})
    return record


def test_a_new_format_is_read_streamed_listed_and_named_from_its_record(tmp_path, json_format):
    run = tmp_path / "runs" / "run1.json"
    run.parent.mkdir()
    time_s, x = np.arange(7.0) * 10, np.linspace(1.0, 2.0, 7)
    run.write_text(json.dumps({"time_s": time_s.tolist(), "x": x.tolist()}))
    (tmp_path / "runs" / "notes.txt").write_text("not a run")
    table = read_table(run)
    assert table.rows == 7 and table.columns["x"].view(np.uint64).tolist() == x.view(np.uint64).tolist()
    assert table.lines.tolist() == list(range(1, 8))
    chunks = list(stream_columns(run, ["time_s", "x"], rows_per_chunk=3))
    assert [c.start for c in chunks] == [0, 3, 6]
    assert np.concatenate([c.columns["x"] for c in chunks]).view(np.uint64).tolist() == x.view(np.uint64).tolist()
    assert recording_paths([str(tmp_path / "runs")]) == [str(run)]
    assert described() == "CSV, .npz, Parquet or JSON columns"


def test_a_bad_file_of_a_new_format_is_refused_in_its_own_words(tmp_path, json_format):
    run = tmp_path / "bad.json"
    run.write_text(json.dumps({"time_s": [0.0, 10.0], "x": [1.0, None]}))
    with pytest.raises(UserError, match=r"bad.json: column 'x': expected finite numbers"):
        read_table(run)


@pytest.mark.parametrize("ending, why", [(".NPZ2", "lower case"), ("npz2", "a '.' first"), (".gz", "end alike"),
                                         (".tsv.csv", "end alike"), (".npz", "end alike")])
def test_a_record_whose_ending_is_wrong_or_claimed_twice_is_refused(monkeypatch, ending, why):
    """A file's name picks one format: an ending that ends as another does ('.csv.gz' and '.gz') would pick two."""
    import thermoplc.recordings.formats as package
    known = list(registry.__wrapped__().values())
    extra = [InputFormat("a", ending, "A", 7, _json_columns, _json_chunks)]
    if ending == ".gz":
        extra.append(InputFormat("b", ".csv.gz", "B", 8, _json_columns, _json_chunks))
    records = {r.name: r for r in [*known, *extra]}
    monkeypatch.setattr(package.pkgutil, "iter_modules", lambda path: [type("M", (), {"name": n}) for n in records])
    monkeypatch.setattr(package.importlib, "import_module",
                        lambda name: type("Module", (), {"FORMAT": records[name.rsplit(".", 1)[1]]}))
    with pytest.raises(RuntimeError, match=why):
        registry.__wrapped__()


def test_a_name_ending_in_a_formats_suffix_in_any_case_is_a_run_of_a_folder(tmp_path):
    (tmp_path / "a.NPZ").write_bytes(b"")
    (tmp_path / "b.Parquet").write_bytes(b"")
    (tmp_path / "c.csv.bak").write_text("")
    assert recording_paths([str(tmp_path)]) == [str(tmp_path / "a.NPZ"), str(tmp_path / "b.Parquet")]
