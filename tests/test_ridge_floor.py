"""The ridge floor beside every cross-validated fit and the shrunk linear kinds in auto's ranking (issue 62, items 1
and 4): the floor is a ridge on the same temperatures' rises held out alike, so mlr (that very ridge) sits on it."""
from __future__ import annotations

import json
import math

import pytest

from benchmarks.campaign import FL_THERMAL, fl_thermal_runs
from tests.cli_runner import thermoplc
from thermoplc.fitting.crossval import fit_held_out
from thermoplc.fitting.fit import FitRequest
from thermoplc.recordings.table import read_table, write_table

TEMPS = ("t8_C", "t4_C", "t5_C", "t11_C")


def test_the_floor_of_a_campaign_is_the_ridge_mlr_fits_whatever_the_kind():
    runs = fl_thermal_runs("ch5_um", 6.0, 0)
    held = {kind: fit_held_out(runs, FitRequest(kind=kind, target="ch5_um", temps=TEMPS, train_until=math.inf),
                               len(runs)).metrics["held_out"] for kind in ("mlr", "gm1n")}
    # the same ridge; only the block's start offset differs
    assert held["mlr"]["rmse_um"] == pytest.approx(held["mlr"]["ridge_rmse_um"], rel=0.02)
    assert held["gm1n"]["ridge_rmse_um"] == held["mlr"]["ridge_rmse_um"]
    assert held["gm1n"]["rmse_um"] != pytest.approx(held["gm1n"]["ridge_rmse_um"], rel=0.05)  # its own fit, not the floor's


def test_one_recording_floor_uses_the_rows_before_each_block(tmp_path):
    out = thermoplc("fit", "--data", FL_THERMAL, "--model", "mlr", "--target", "ch3_um", "--temps", "t5_C,t4_C",
                    "--folds", 4, "-o", "m.json", cwd=tmp_path).stdout
    held = json.loads((tmp_path / "m.json").read_text())["metrics"]["held_out"]
    assert held["rmse_um"] == pytest.approx(held["ridge_rmse_um"], rel=0.02)
    assert (f"a ridge on the same temperatures' rises, held out alike: {held['ridge_rmse_um']:.3f} um; this model "
            f"{held['rmse_um'] / held['ridge_rmse_um']:.2f} x that") in out
    assert read_table(FL_THERMAL).rows > held["rows"]


@pytest.mark.slow
def test_auto_ranks_mlr_and_dlag_on_every_sensor_beside_the_chosen_ones(tmp_path):
    (tmp_path / "runs").mkdir()
    for k, table in enumerate(fl_thermal_runs("ch5_um", 6.0, 0)[:5], start=1):
        (tmp_path / "runs" / f"run{k}.csv").write_text(write_table(dict(table.columns)))
    every = "t1_C,t3_C,t4_C,t5_C,t8_C,t11_C"
    out = thermoplc("fit", "--data", "runs", "--model", "auto", "--target", "ch5_um", "--temps", every, "--folds", 5,
                    "-o", "auto.json", cwd=tmp_path).stdout
    ranking = json.loads((tmp_path / "auto.json").read_text())["metrics"]["auto_ranking"]
    shrunk = [r for r in ranking if r["sensors"] == every.split(",")]
    assert sorted((r["kind"], r.get("options")) for r in shrunk) == [
        ("bayes", {"--parents": "ridge"}), ("bpnn", {"--skip": "ridge"}), ("dlag", None), ("mlr", None)]
    assert "also on every sensor, ridge-shrunk" in out and "bayes --parents ridge" in out
    assert f"bayes   {every} --parents ridge" in out  # the ranking row says which bayes it is


@pytest.mark.parametrize("target, lags_kept, ratio", [("ch3_um", False, 1.05), ("ch5_um", True, 1.0)])
def test_dlag_keeps_its_lags_only_where_they_beat_the_current_rises_on_the_runs_left_out(target, lags_kept, ratio):
    """FL_THERMAL in 6 h runs, every sensor (ambient t6 apart): the lagged rises (3 x 600 s) alone are 1.27 x the
    floor held out on ch3. Each fit compares its lagged ridge with the current rises alone, each run predicted
    by the others with the weight chosen without it, and keeps the lags only where they win by a standard error:
    ch3 1.02 x (1.12 x when the best weight's own error compared them), ch5 0.96 x with the lags kept."""
    every = tuple(f"t{i}_C" for i in range(1, 17) if i != 6)
    runs = fl_thermal_runs(target, 6.0, 0)
    model = fit_held_out(runs, FitRequest(kind="dlag", target=target, temps=every, train_until=math.inf), len(runs))
    held = model.metrics["held_out"]
    assert held["rmse_um"] <= ratio * held["ridge_rmse_um"], held
    lags = [model.coef(f"beta_{i}_{lag}") for i in range(1, len(every) + 1) for lag in (1, 2, 3)]
    assert any(lags) is lags_kept and ("the lags' coefficients are 0" in model.fit["method"]) is not lags_kept
