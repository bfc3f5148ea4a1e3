"""Long recordings and fleets: streamed CSV reading, .npz input, verify --manifest --jobs."""
import numpy as np
import pytest

from tests.golden_models import GOLDEN, golden_block, golden_twin_csv
from tests.cli_runner import thermoplc
from thermoplc.base.errors import UserError
from thermoplc.recordings import table as table_module
from thermoplc.recordings.table import read_table


def test_streamed_reading_equals_whole_reading_and_points_at_late_lines(tmp_path, monkeypatch):
    path = golden_twin_csv(tmp_path)
    whole = read_table(path)
    monkeypatch.setattr(table_module, "CHUNK_ROWS", 1000)
    streamed = read_table(path)
    assert streamed.columns.keys() == whole.columns.keys()
    for name in whole.columns:
        assert np.array_equal(streamed.columns[name].view(np.uint64), whole.columns[name].view(np.uint64))
    assert np.array_equal(streamed.lines, np.arange(2, whole.rows + 2))
    lines = path.read_text().splitlines()
    cells = lines[3500].split(",")
    cells[4] = "n/a"
    lines[3500] = ",".join(cells)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(UserError, match=r"bad.csv:3501:5: column 'T_motor': expected a number, found 'n/a'"):
        read_table(bad)


def test_npz_input_verifies_like_the_csv(tmp_path):
    csv_path = golden_twin_csv(tmp_path)
    table = read_table(csv_path)
    np.savez(tmp_path / "twin.npz", **table.columns)
    for data in (csv_path, tmp_path / "twin.npz"):
        out = thermoplc("verify", golden_block("kalman", "tia"), "--model", GOLDEN / "kalman.json", "--data", data,
                        cwd=tmp_path).stdout
        assert f"{table.rows} cycles" in out and out.startswith("bit-exact")
    np.savez(tmp_path / "ragged.npz", time_s=np.arange(3.0), T_motor=np.arange(4.0))
    result = thermoplc("verify", golden_block("mlr", "tia"), "--model", GOLDEN / "mlr.json", "--data",
                       tmp_path / "ragged.npz", cwd=tmp_path, check=2)
    assert "every array must be one column of the same length" in result.stderr


def test_manifest_verifies_pairs_in_parallel_in_manifest_order(tmp_path):
    data = golden_twin_csv(tmp_path)
    edited = tmp_path / "edited.scl"
    edited.write_text(golden_block("mlr", "tia").read_text().replace("c_beta0 : Real := ", "c_beta0 : Real := 1"))
    (tmp_path / "fleet.csv").write_text(
        "block,data,model\n"
        f"{golden_block('kalman', 'tia')},{data.name},{GOLDEN / 'kalman.json'}\n"
        f"{golden_block('mlr', 'iec')},{data.name},{GOLDEN / 'mlr.json'}\n"
        f"edited.scl,{data.name},{GOLDEN / 'mlr.json'}\n")
    result = thermoplc("verify", "--manifest", "fleet.csv", "--jobs", "2", cwd=tmp_path, check=1)
    rows = result.stdout.splitlines()[1:4]
    assert [r.split()[1] for r in rows] == ["bit-exact", "bit-exact", "NOT"]
    assert "3 pairs: 2 bit-exact, 1 NOT bit-exact, 0 error" in result.stdout
    (tmp_path / "bad.csv").write_text("block,data\nx.scl,y.csv\n")
    result = thermoplc("verify", "--manifest", "bad.csv", cwd=tmp_path, check=2)
    assert "bad.csv:2: give either a model or an expect column value, not neither" in result.stderr
