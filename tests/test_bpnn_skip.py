"""Issue 62: paper 002's network beside a ridge (`--skip ridge`): at the floor on a real campaign, bit-exact,
every weight of the skip path checked, and the network left at 0 um where the runs it did not train on say so."""
import json
import math

import numpy as np

from tests.conftest import fit_small
from tests.test_bayes import _constant_mutants
from thermoplc.fitting.fit import FitRequest
from thermoplc.generator.lower import lower
from thermoplc.generator.printer import render
from thermoplc.verifier.replays.replay import verify_against_model

FOUR = ("t8_C", "t4_C", "t5_C", "t11_C")


def test_on_a_real_campaign_the_skip_path_keeps_the_network_at_the_floor():
    """FL_THERMAL ch5 in 6 h runs probed every 30 min, each run predicted from the others: paper 002's network
    alone is 1.76 x a ridge on the same four sensors' rises (its error on the runs it never saw grows where the
    training runs' range ends); beside a ridge, stopped early on runs it did not train on, 0.99 x."""
    from benchmarks.campaign import fl_thermal_runs
    from thermoplc.fitting.crossval import fit_held_out
    runs = fl_thermal_runs("ch5_um", 6.0, 30.0)

    def held(settings: dict) -> dict:
        request = FitRequest(kind="bpnn", target="ch5_um", temps=FOUR, train_until=math.inf, settings=settings)
        return fit_held_out(runs, request, len(runs)).metrics["held_out"]
    skip, paper = held({"skip": "ridge"}), held({})
    assert skip["rmse_um"] <= 1.1 * skip["ridge_rmse_um"], skip
    assert paper["rmse_um"] > 1.5 * paper["ridge_rmse_um"], paper


def test_the_skip_block_is_bit_exact_and_every_weight_is_checked(twin_table, tmp_path):
    model = fit_small(twin_table, "bpnn", skip="ridge")
    assert model.settings["skip"] == "ridge" and "plus a network fitted to what it leaves" in model.fit["method"]
    assert model.fit["early_stopping"]["validation"] == "the last fifth of the rows"
    model_path = tmp_path / "bpnn.json"
    model_path.write_text(model.to_json())
    text = render(lower(model))
    (tmp_path / "bpnn.scl").write_text(text)
    assert "Ridge := " in text
    assert verify_against_model(str(tmp_path / "bpnn.scl"), model, str(model_path), twin_table).ok
    mutants = list(_constant_mutants(text, "ridge1"))
    assert [name for name, _ in mutants] == [f"c_ridge1_{i}" for i in range(len(model.signals("temperature")) + 1)]
    for name, mutant in mutants:
        (tmp_path / "mutant.scl").write_text(mutant)
        report = verify_against_model(str(tmp_path / "mutant.scl"), model, str(model_path), twin_table)
        assert not report.ok and any(e.startswith(name) for e in report.constant_errors), name


def test_a_network_the_validation_runs_do_not_confirm_stays_at_0_um():
    """Error exactly linear in the rises: the ridge takes all of it, back-propagation never lowers the
    validation error below its start, and the block's output is the ridge's to within the rounding of 0 um."""
    from thermoplc.models.kinds.bpnn import fit_bpnn
    rng = np.random.default_rng(3)
    rises = np.cumsum(rng.normal(0.0, 0.05, (600, 3)), axis=0)
    residual = rng.normal(0.0, 0.2, (600, 1))  # what a ridge leaves of a linear error: noise
    coefficients, _, log = fit_bpnn(rises, residual, ["a", "b", "c"], 1, 8, 3, epochs=300, runs=[200, 200, 200],
                                    from_zero=True)
    assert log["early_stopping"] == {**log["early_stopping"], "epochs": 0,
                                     "validation": "3 groups of 3 runs, each left out in turn"}
    hidden = sum(1 for name in coefficients if name.startswith("w2_1_"))
    assert all(coefficients[f"w2_1_{j}"].f64 == 0.0 for j in range(1, hidden + 1))
    out = coefficients["b2_1"].f64 * coefficients["out_scale_1"].f64 + coefficients["out_shift_1"].f64
    assert abs(out) < 1e-9


def test_skip_on_the_command_line_fits_generates_and_verifies_a_campaign(tmp_path):
    from benchmarks.campaign import fl_thermal_runs
    from tests.cli_runner import thermoplc
    from thermoplc.recordings.table import write_table
    (tmp_path / "runs").mkdir()
    for k, run in enumerate(fl_thermal_runs("ch3_um", 6.0, 0)[:4], start=1):
        (tmp_path / "runs" / f"run{k}.csv").write_text(write_table({c: run.columns[c]
                                                                    for c in ("time_s", *FOUR, "ch3_um")}))
    thermoplc("fit", "--data", "runs", "--model", "bpnn", "--skip", "ridge", "--target", "ch3_um", "--temps",
              ",".join(FOUR), "--population", 8, "--generations", 3, "--folds", 4, "-o", "m.json",
              cwd=tmp_path)
    model = json.loads((tmp_path / "m.json").read_text())
    assert model["settings"]["skip"] == "ridge"
    assert model["fit"]["early_stopping"]["validation"].endswith(" runs, each left out in turn")
    thermoplc("generate", "m.json", "-o", "m.scl", "--accept-unvalidated", cwd=tmp_path)
    out = thermoplc("verify", "m.scl", "--model", "m.json", "--data", "runs", cwd=tmp_path).stdout
    assert "bit-exact: every run reproduces the reference (4 runs" in out
    refused = thermoplc("fit", "--data", "runs", "--model", "mlr", "--skip", "ridge", "--target", "ch3_um", "--temps",
                        ",".join(FOUR), "--folds", 4, "-o", "x.json", cwd=tmp_path, check=2)
    assert "--skip is" in refused.stderr and not (tmp_path / "x.json").exists()
    model["settings"]["skip"] = "none"  # weights without their path: refused, not declared and left unused
    (tmp_path / "stray.json").write_text(json.dumps(model))
    refused = thermoplc("generate", "stray.json", "-o", "s.scl", cwd=tmp_path, check=2)
    assert "ridge1_0" in refused.stderr and "without a skip path" in refused.stderr
    model["settings"]["skip"] = "ridge"
    del model["coefficients"]["ridge1_2"]
    (tmp_path / "broken.json").write_text(json.dumps(model))
    refused = thermoplc("generate", "broken.json", "-o", "b.scl", cwd=tmp_path, check=2)
    assert "ridge1_2" in refused.stderr and "broken.json" in refused.stderr and not (tmp_path / "b.scl").exists()
