"""The held-out evidence of a campaign replays each run through its fold's block as the PLC runs it (issue 62,
item 2): an input outside what the training runs saw is a fault the block holds on, not a value the model
extrapolates to, and the figure and the run that raised it are said beside the model's own."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from benchmarks.campaign import fl_thermal_runs
from tests.cli_runner import thermoplc
from thermoplc.fitting.crossval import fit_held_out
from thermoplc.fitting.fit import FitRequest
from thermoplc.recordings.table import write_table

TEMPS = ("t8_C", "t4_C", "t5_C", "t11_C")
REQUEST = FitRequest(kind="mlr", target="ch5_um", temps=TEMPS, train_until=math.inf, keep_every_run=True)


def _offset(table, column: str, kelvin: float):
    """A sensor reading `kelvin` high from its run's first row: its rises, and so mlr's prediction, unchanged."""
    return replace(table, columns={**table.columns, column: table.columns[column] + kelvin})


@pytest.fixture(scope="module")
def runs():
    return fl_thermal_runs("ch5_um", 6.0, 0)


def test_a_run_outside_the_training_runs_guards_is_judged_as_its_block_holds(runs):
    clean = fit_held_out(runs, REQUEST, len(runs)).metrics
    planted = fit_held_out([*runs[:2], _offset(runs[2], "t4_C", 40.0), *runs[3:]], REQUEST, len(runs)).metrics
    assert clean["held_out"]["block_flagged_runs"] == []
    for run in clean["runs"]:  # inside the guards the block is the model, to float32
        assert run["block_rmse"] == pytest.approx(run["rmse"], abs=0.01)
    assert planted["held_out"]["rmse_um"] == pytest.approx(clean["held_out"]["rmse_um"], rel=1e-5)  # rises: blind to it
    third = planted["runs"][2]
    assert planted["held_out"]["block_flagged_runs"] == [third["run"]]
    assert third["block_flagged_from_call"] == 1
    assert third["rmse"] * 2 < third["block_rmse"] <= third["zero_rmse"]  # held: never worse than none
    assert planted["held_out"]["block_rmse_um"] > planted["held_out"]["rmse_um"]
    for before, after in zip(clean["runs"][3:], planted["runs"][3:]):
        assert after["block_rmse"] == pytest.approx(before["block_rmse"], rel=1e-5)


def test_fit_prints_the_figure_as_the_plc_runs_it(runs, tmp_path):
    (tmp_path / "runs").mkdir()
    for k, table in enumerate([*runs[:2], _offset(runs[2], "t4_C", 40.0), *runs[3:]], start=1):
        (tmp_path / "runs" / f"run{k}.csv").write_text(write_table(dict(table.columns)))
    out = thermoplc("fit", "--data", "runs", "--model", "mlr", "--target", "ch5_um", "--temps", ",".join(TEMPS),
                    "--folds", 8, "--keep-every-run", "-o", "m.json", cwd=tmp_path).stdout
    line = next(x for x in out.splitlines() if "as the PLC runs each fold's block" in x)
    assert "a fault or disagreement raised on 1 of 8 runs: run3.csv" in line
