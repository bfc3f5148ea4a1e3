"""Blocked cross-validation: whole contiguous blocks, folds that run forward, recordings as folds."""
import json
from pathlib import Path

import numpy as np
import pytest

from tests.cli_runner import thermoplc
from thermoplc.base.errors import UserError
from thermoplc.fitting import crossval
from thermoplc.recordings.table import Table
from thermoplc import api

FL_THERMAL = Path(api.__file__).parent / "data" / "fl_thermal" / "fl_thermal.csv"  # the copy the package ships


def _table(rows: int, speed: np.ndarray | None = None) -> Table:
    columns = {"time_s": 10.0 * np.arange(rows)}
    if speed is not None:
        columns["n"] = speed
    return Table("t.csv", columns, "0", np.arange(1, rows + 1))


def test_blocks_have_equal_durations_and_cuts_move_to_the_nearest_standstill():
    assert crossval.cuts(_table(1000), "time_s", 4, None) == [250, 500, 750]
    speed = np.full(1000, 3000.0)
    speed[[230, 540, 600, 990]] = 0.0  # standstills near the first two cuts; none within reach of the third
    assert crossval.cuts(_table(1000, speed), "time_s", 4, "n") == [230, 540, 750]


@pytest.mark.parametrize("folds, rows", [(1, 1000), (21, 1000), (5, 40)])
def test_too_few_or_too_many_blocks_are_refused(folds, rows):
    with pytest.raises(UserError, match="--folds"):
        crossval.cuts(_table(rows), "time_s", folds, None)


def test_pooled_errors_weigh_each_fold_by_its_rows():
    folds = [crossval.Fold("a", 10, 100, 1.0, 2.0, 4.0, 5.0), crossval.Fold("b", 110, 300, 3.0, 7.0, 4.0, 9.0)]
    pooled = crossval.pooled(folds)
    assert pooled["rows"] == 400 and pooled["rmse_um"] == pytest.approx(np.sqrt((100 * 1 + 300 * 9) / 400))
    assert pooled["max_abs_um"] == 7.0 and pooled["zero_rmse_um"] == pytest.approx(4.0)
    assert pooled["fold_rmse_um"] == [1.0, 3.0]


def test_fit_with_folds_fits_every_row_and_no_fold_predicts_rows_it_was_fitted_on(tmp_path):
    thermoplc("twin", "--hours", 12, "--seed", 4, "-o", "twin.csv", cwd=tmp_path)
    fitted = thermoplc("fit", "--data", "twin.csv", "--model", "lumped", "--target", "E_z_um", "--temps",
                       "T_motor,T_bearing", "--speed", "n_rpm", "--ambient", "T_env", "--folds", 3, "-o", "m.json",
                       cwd=tmp_path)
    assert "forward cross-validation over 3 blocks: each fold predicted by a fit that never saw it" in fitted.stdout
    model = json.loads((tmp_path / "m.json").read_text())
    assert model["training"]["rows"] == model["training"]["total_rows"] == 4321
    folds = model["metrics"]["cross_validation"]
    assert len(folds) == 2
    previous_end = None
    for fold in folds:
        first, last = map(int, fold["label"].removeprefix("rows ").split(".."))
        assert fold["train_rows"] == first - 1 and fold["rows"] == last - first + 1  # fitted strictly before
        assert previous_end is None or first == previous_end + 1  # blocks follow each other, never overlap
        previous_end = last
    held = model["metrics"]["held_out"]
    assert held["rows"] == sum(f["rows"] for f in folds) and held["protocol"] == "forward cross-validation over 3 blocks"
    accepted = thermoplc("generate", "m.json", "-o", "m.scl", cwd=tmp_path)
    assert "(forward cross-validation over 3 blocks)" in accepted.stdout


def test_folds_exclude_a_training_part_and_a_count_out_of_range(tmp_path):
    thermoplc("twin", "--hours", 2, "--seed", 4, "-o", "twin.csv", cwd=tmp_path)
    common = ("fit", "--data", "twin.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing")
    both = thermoplc(*common, "--folds", 3, "--train-until", 3600, "-o", "m.json", cwd=tmp_path, check=2)
    assert "not allowed with argument" in both.stderr
    for count in (1, "x"):
        refused = thermoplc(*common, "--folds", count, "-o", "m.json", cwd=tmp_path, check=2)
        assert "argument --folds: expected" in refused.stderr and "Traceback" not in refused.stderr
    blocks = thermoplc(*common, "--folds", 21, "-o", "m.json", cwd=tmp_path, check=2)  # runs may be more
    assert "--folds 21: expected 2 to 20 blocks" in blocks.stderr
    assert not (tmp_path / "m.json").exists()


def test_several_recordings_are_folds_of_their_own(tmp_path):
    from tests.golden_models import batch_csvs
    paths = batch_csvs(tmp_path)
    data = [x for p in paths for x in ("--data", p.name)]
    thermoplc("fit", *data, "--model", "piecewise", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "--ambient",
              "T_env", "--folds", len(paths), "-o", "p.json", cwd=tmp_path)
    model = json.loads((tmp_path / "p.json").read_text())
    assert [f["label"] for f in model["metrics"]["cross_validation"]] == [p.name for p in paths]
    assert model["metrics"]["held_out"]["protocol"] == f"leave-one-run-out cross-validation over {len(paths)} runs"


def test_on_fl_thermal_forward_folds_show_the_spread_a_single_split_hides(tmp_path):
    fitted = thermoplc("fit", "--data", FL_THERMAL, "--model", "dlag", "--target", "ch5_um", "--temps",
                       "t8_C,t4_C,t5_C,t11_C", "--folds", 4, "-o", "d.json", cwd=tmp_path)
    assert "  spread: fold RMSE 4.028 to 16.337 um" in fitted.stdout
    assert "  all folds (8336 rows)                     10.892   28.797        23.769       39.134" in fitted.stdout


def test_several_recordings_need_one_fold_each_and_no_copies(tmp_path):
    from tests.golden_models import batch_csvs
    paths = batch_csvs(tmp_path)
    common = ("fit", "--model", "piecewise", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "--ambient",
              "T_env", "-o", "p.json")
    data = [x for p in paths for x in ("--data", p.name)]
    wrong = thermoplc(*common, *data, "--folds", 7, cwd=tmp_path, check=2)
    assert f"--folds 7: with {len(paths)} runs expected 2 to {len(paths)} folds" in wrong.stderr
    (tmp_path / "copy.csv").write_text(paths[0].read_text())
    copied = thermoplc(*common, *data, "--data", "copy.csv", "--folds", len(paths) + 1, cwd=tmp_path, check=2)
    assert f"copy.csv: the same recording as {paths[0].name}" in copied.stderr


def test_a_run_in_other_bytes_is_the_same_run(tmp_path):
    """Issue 60: the same run as Parquet, with CRLF line endings, or with its columns reordered, semicolons and
    decimal commas is refused naming both files, by fit and diagnose alike; so is a copy one cell apart."""
    import pyarrow.csv
    import pyarrow.parquet
    from tests.golden_models import batch_csvs
    paths = batch_csvs(tmp_path)
    common = ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "-o", "m.json")
    data = [x for p in paths for x in ("--data", p.name)]
    text = paths[1].read_text()
    header, *rows = text.splitlines()
    flipped = [";".join(reversed(line.split(","))).replace(".", ",") for line in (header, *rows)]
    copies = {"copy.parquet": None, "crlf.csv": text.replace("\n", "\r\n"), "flipped.csv": "\n".join(flipped) + "\n"}
    pyarrow.parquet.write_table(pyarrow.csv.read_csv(paths[1]), tmp_path / "copy.parquet")
    for name, content in copies.items():
        if content is not None:
            (tmp_path / name).write_text(content, newline="")
        refused = thermoplc(*common, *data, "--data", name, "--folds", len(paths) + 1, cwd=tmp_path, check=2)
        assert refused.stderr.startswith(f"thermoplc: error: {name}: the same recording as {paths[1].name} (the same "
                                         f"columns and numbers in other bytes)"), refused.stderr
        assert not (tmp_path / "m.json").exists()
    diagnosed = thermoplc("diagnose", *data, "--data", "crlf.csv", "--temps", "T_motor", "--speed", "n_rpm",
                          "--ambient", "T_env", "--target", "E_z_um", cwd=tmp_path, check=2)
    assert f"crlf.csv: the same recording as {paths[1].name}" in diagnosed.stderr
    (tmp_path / "crlf.csv").write_text(text.replace("\n", "\r\n").replace(rows[5], rows[5].replace(",", ",1", 1), 1),
                                       newline="")  # one cell apart: still the same run, in part
    edited = thermoplc(*common, *data, "--data", "crlf.csv", "--folds", len(paths) + 1, cwd=tmp_path, check=2)
    assert f"of {paths[1].name} (a copy of one recording, in part or with other bytes)" in edited.stderr


def test_a_piece_of_a_run_or_a_copy_with_other_time_stamps_is_no_held_out_run(tmp_path):
    """Hostile review of issue 60: a copy with its time shifted, a column the model does not read dropped, or
    half of a run in a file of its own fitted as a run of its own; now refused naming where both files agree.
    A campaign of distinct runs (the twin's, FL_THERMAL cut in four) is taken."""
    from tests.golden_models import batch_csvs
    paths = batch_csvs(tmp_path)
    common = ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "-o", "m.json")
    data = [x for p in paths for x in ("--data", p.name)]
    header, *rows = paths[1].read_text().splitlines()
    shifted = [",".join([f"{float(r.split(',')[0]) + 1e5:g}", *r.split(",")[1:]]) for r in rows]
    dropped = [",".join(r.split(",")[:-1]) for r in [header, *rows]]  # the last column: no input of the model
    pieces = {"shifted.csv": "\n".join([header, *shifted]), "dropped.csv": "\n".join(dropped),
              "half.csv": "\n".join([header, *rows[len(rows) // 2:]])}
    for name, text in pieces.items():
        (tmp_path / name).write_text(text + "\n")
        refused = thermoplc(*common, *data, "--data", name, "--folds", len(paths) + 1, cwd=tmp_path, check=2)
        assert f"hold the same values of T_motor, T_bearing, E_z_um, in the same order, as calls" in refused.stderr
        assert paths[1].name in refused.stderr and name in refused.stderr and not (tmp_path / "m.json").exists()
    thermoplc(*common, *data, "--folds", len(paths), cwd=tmp_path)
