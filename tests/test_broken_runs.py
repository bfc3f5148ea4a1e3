"""A broken run in a campaign (issue 62, item 2): refused for training by name, its sensor named, reported apart,
and the model written the very one fitted on the campaign without it; nothing refused on real or twin campaigns."""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.broken_runs import broken
from benchmarks.campaign import fl_thermal_runs, twin_runs
from tests.cli_runner import thermoplc
from thermoplc.fitting.broken_runs import screen_runs
from thermoplc.machines.campaign import TARGET
from thermoplc.models.modelfile import load_model
from thermoplc.recordings.table import write_table

TEMPS = ("t8_C", "t4_C", "t5_C", "t11_C")
FIT = ("fit", "--model", "mlr", "--target", "ch5_um", "--temps", ",".join(TEMPS), "--folds", 8)


def _write(folder, tables) -> None:
    folder.mkdir()
    for k, table in enumerate(tables, start=1):
        (folder / f"run{k}.csv").write_text(write_table(dict(table.columns)))


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory):
    """FL_THERMAL in 6 h runs: as recorded, with run 4's t8_C jumping 6.5 K mid-run and rising 25 K more, and
    without run 4."""
    root = tmp_path_factory.mktemp("broken")
    runs = fl_thermal_runs("ch5_um", 6.0, 0)
    _write(root / "broken", [*runs[:3], broken(runs[3], "jump", "t8_C", "t4_C"), *runs[4:]])
    _write(root / "without", runs[:3] + runs[4:])
    return root


@pytest.mark.parametrize("hours", [3.0, 6.0])
def test_no_run_of_the_real_recording_is_refused(hours):
    for target, temps in (("ch3_um", ("t5_C", "t4_C")), ("ch5_um", TEMPS)):
        assert screen_runs(fl_thermal_runs(target, hours, 0), temps, target).refused == ()


@pytest.mark.parametrize("machine", ["cascade", "portal"])
def test_no_run_of_a_twin_campaign_is_refused(machine):
    tables = twin_runs(machine, 2, 10, 6.0, 0.0).tables
    temps = tuple(c for c in tables[0].columns if c.startswith("T_") and c != "T_env")[:3]
    assert screen_runs(tables, temps, TARGET).refused == ()


@pytest.mark.parametrize("fault", ["jump", "swap"])
def test_a_broken_channel_is_refused_and_named(fault):
    runs = fl_thermal_runs("ch5_um", 6.0, 0)
    runs[3] = broken(runs[3], fault, "t8_C", "t4_C")
    screening = screen_runs(runs, TEMPS, "ch5_um")
    assert [(r.index, r.run, r.sensor) for r in screening.refused] == [(3, "fl_thermal_run4.csv", "t8_C")]
    assert screening.refused[0].difference_K > screening.refused[0].gate_K and screening.refused[0].ratio >= 2


def test_fit_refuses_the_run_and_writes_the_model_of_the_campaign_without_it(campaigns):
    out = thermoplc(*FIT, "--data", "broken", "-o", "screened.json", cwd=campaigns).stdout
    thermoplc(*FIT[:-1], 7, "--data", "without", "-o", "without.json", cwd=campaigns)
    assert "REFUSED for training: run4.csv: t8_C" in out
    assert "leave-one-run-out cross-validation over 7 runs; 1 run refused for training" in out
    screened, without = load_model(str(campaigns / "screened.json")), load_model(str(campaigns / "without.json"))
    bits = lambda m: {k: c.f32 for k, c in m.coefficients.items()}
    assert bits(screened) == bits(without)
    assert screened.metrics["held_out"]["rmse_um"] == pytest.approx(without.metrics["held_out"]["rmse_um"], rel=1e-12)
    refused = screened.metrics["refused_runs"]
    assert [r["run"] for r in refused] == ["run4.csv"] and refused[0]["sensor"] == "t8_C"
    with_them = screened.metrics["held_out"]["with_refused_runs"]
    rows = screened.metrics["held_out"]["rows"] + refused[0]["rows"]
    assert with_them["rows"] == rows
    pooled = math.sqrt((screened.metrics["held_out"]["rmse_um"] ** 2 * screened.metrics["held_out"]["rows"]
                        + refused[0]["rmse"] ** 2 * refused[0]["rows"]) / rows)
    assert with_them["rmse_um"] == pytest.approx(pooled, rel=1e-9)
    assert f"held out with the refused runs: {with_them['rmse_um']:.3f} um" in out
    # the PLC's block on the broken run: its guards hold it, so it stays nearer the drift than no compensation
    assert refused[0]["block_rmse"] < refused[0]["zero_rmse"] < refused[0]["rmse"]
    assert refused[0]["block_flagged_from_call"] is not None
    assert f"its block, guards acting, {refused[0]['block_rmse']:.3f} um" in out
    assert "run4.csv" not in [b["file"] for b in screened.training["batches"]]


def test_keep_every_run_trains_on_the_broken_run(campaigns):
    out = thermoplc(*FIT, "--data", "broken", "--keep-every-run", "-o", "kept.json", cwd=campaigns).stdout
    assert "REFUSED" not in out and "over 8 runs" in out
    kept = load_model(str(campaigns / "kept.json"))
    assert "refused_runs" not in kept.metrics and len(kept.training["batches"]) == 8


def test_the_fusion_is_not_chosen_on_the_refused_run(campaigns):
    thermoplc(*FIT, "--data", "broken", "--probe", "--probe-every", 45, "-o", "fused.json", cwd=campaigns)
    probing = load_model(str(campaigns / "fused.json")).metrics["probing"]
    assert "run4.csv" not in [r["run"] for r in probing["runs"]] and len(probing["runs"]) == 7


def test_groups_leave_the_refused_run_out(campaigns):
    table = "file,half\n" + "".join(f"run{k}.csv,{'a' if k <= 4 else 'b'}\n" for k in range(1, 9))
    (campaigns / "broken" / "runs.csv").write_text(table)
    out = thermoplc("fit", "--model", "mlr", "--target", "ch5_um", "--temps", ",".join(TEMPS), "--data", "broken",
                    "--group-by", "half", "-o", "grouped.json", cwd=campaigns).stdout
    (campaigns / "broken" / "runs.csv").unlink()
    assert "leave-one-group-out cross-validation over 2 groups of 7 runs; 1 run refused for training" in out
    runs = load_model(str(campaigns / "grouped.json")).metrics["runs"]
    assert [r["run"] for r in runs] == [f"run{k}.csv" for k in (1, 2, 3, 5, 6, 7, 8)]


def test_a_fusion_that_loses_to_its_reset_on_the_held_out_runs_gives_way_to_it():
    from thermoplc.fitting.probe_fit import Errors, PLAIN, ProbeRun, _worse_than_reset, choose
    run = lambda fused, reset: {"fused": Errors(fused, 10, fused, 2), "reset": Errors(reset, 10, reset, 2)}
    assert _worse_than_reset({"runs": [run(4.0, 1.0), run(1.0, 1.0)]}, True).startswith("the fusion chosen was 1.58 x")
    assert _worse_than_reset({"runs": [run(1.0, 1.0), run(0.5, 1.0)]}, True) is None
    rng = np.random.default_rng(3)
    target = np.cumsum(rng.normal(0, 0.2, 400))
    runs = [ProbeRun(f"r{k}", target * (1 + 0.1 * k), target, np.ones(400, bool)) for k in range(3)]
    fusion, evidence = choose(runs, 10.0, 60.0, 100.0, plain_only=True)
    assert (fusion.value("gain", "f64"), fusion.has_rate, fusion.decay) == (PLAIN[0], False, None)
    assert evidence["nested"] and fusion.value("gate_um", "f64") < 100.0


def test_keep_every_run_without_a_campaign_is_refused(campaigns):
    alone = thermoplc(*FIT[:-2], "--train-until", 10000, "--data", "broken/run1.csv", "--keep-every-run", "-o",
                      "one.json", cwd=campaigns, check=2)
    assert "--keep-every-run keeps a campaign's runs" in alone.stderr and not (campaigns / "one.json").exists()


@pytest.fixture(scope="module")
def unrelated(tmp_path_factory):
    """FL_THERMAL's temperatures in 6 h runs under a drift they say nothing of (a smoothed random walk per run)."""
    root = tmp_path_factory.mktemp("unrelated")
    rng = np.random.default_rng(7)
    runs = []
    for table in fl_thermal_runs("ch5_um", 6.0, 0):
        walk = np.convolve(np.cumsum(rng.normal(0, 1, table.rows)), np.ones(60) / 60, mode="same")
        runs.append(type(table)(table.path, {**table.columns, "ch5_um": np.round(0.8 * (walk - walk[0]), 3)},
                                table.sha256, table.lines))
    _write(root / "runs", runs)
    return root


def test_a_static_part_that_fails_gives_an_offset_only_block_that_passes_and_verifies(unrelated):
    from thermoplc.fitting.acceptance import refusal
    from thermoplc.fitting.offset_only import is_offset_only
    out = thermoplc(*FIT, "--data", "runs", "--probe", "--probe-every", 45, "-o", "off.json", cwd=unrelated).stdout
    assert "OFFSET-ONLY: the static part fails generate's rule" in out
    model = load_model(str(unrelated / "off.json"))
    assert is_offset_only(model) and refusal(model) is None
    pooled = model.metrics["probing"]["pooled"]
    assert pooled["fused_rmse_um"] < 0.2 * pooled["none_rmse_um"] and pooled["static_rmse_um"] == pooled["none_rmse_um"]
    static = thermoplc(*FIT, "--data", "runs", "-o", "static.json", cwd=unrelated).stderr
    assert "generate will refuse this model" in static
    generated = thermoplc("generate", "off.json", "-o", "Off.scl", cwd=unrelated).stdout
    assert "offset-only: 0 between probings" in generated
    verified = thermoplc("verify", "Off.scl", "--model", "off.json", "--data", "runs", "--probe-every", 45,
                         cwd=unrelated).stdout
    assert "bit-exact: every run reproduces the reference (8 runs" in verified
