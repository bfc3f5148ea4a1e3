"""The identified lumped model (physics/identify.py): the filter gain the prediction-error fit finds
is the steady-state Kalman gain of the noise in the data, and on the real recording the block
beats no compensation held out."""
import json
from pathlib import Path

import numpy as np
import pytest

from tests.cli_runner import thermoplc
from thermoplc.physics import identify
from thermoplc.physics.primitives import Series, Shared
from thermoplc import api

DT = 15.0
FL_THERMAL = Path(api.__file__).parent / "data" / "fl_thermal" / "fl_thermal.csv"  # the copy the package ships


def _kalman_gain(a: float, process: float, measurement: float) -> float:
    """Steady-state filtered gain of x[j] = a x[j-1] + w, y = x + v (the Riccati recursion to its fixed point)."""
    p = measurement
    for _ in range(10_000):
        predicted = a * a * p + process
        p = predicted * measurement / (predicted + measurement)
    return predicted / (predicted + measurement)


def _node(seed: int, process_sigma: float, rows: int = 6000, tau_s: float = 1800.0):
    """One sensor node with process noise, read with 0.02 K noise; speed in steps, a slow ambient."""
    rng = np.random.default_rng(seed)
    t = np.arange(rows) * DT
    n = np.repeat(rng.choice([0.0, 1500.0, 3000.0, 4500.0], rows // 400 + 1), 400)[:rows]
    te = 20.0 + 1.5 * np.sin(2 * np.pi * t / 86400.0)
    a = np.exp(-DT / tau_s)
    x = np.empty(rows)
    previous = 24.0
    for j in range(rows):
        previous = a * previous + (1 - a) * (te[j] + 3.0 + 0.004 * n[j]) + process_sigma * rng.standard_normal()
        x[j] = previous
    y = x + 0.02 * rng.standard_normal(rows)
    series = Series(DT, t, n, te, y[:, None], ("T",), np.zeros(rows))
    return series, a


@pytest.mark.parametrize("process_sigma", [0.0, 0.005, 0.02, 0.08])
def test_filter_gain_is_the_kalman_gain_of_the_noise(process_sigma):
    series, a = _node(3, process_sigma)
    fitted = identify.fit_sensor([series], 0, Shared(stopped_rpm=0.0))
    want = _kalman_gain(a, process_sigma ** 2, 0.02 ** 2) if process_sigma else 0.0
    assert abs(fitted.filter_gain - want) < 0.06 + 0.15 * want, (fitted.filter_gain, want)
    assert abs(fitted.tau_s - 1800.0) < 0.15 * 1800.0 or process_sigma >= 0.08  # a random walk hides the pole
    if process_sigma <= 0.005:  # the model explains the data: gains recovered
        assert abs(fitted.gain - 0.004) < 2e-4 and abs(fitted.load_K - 3.0) < 0.3


def test_a_model_that_fits_keeps_the_filter_gain_small_and_one_step_equals_open_loop():
    series, _ = _node(4, 0.0)
    sim, measured = identify.fit([series])
    assert sim.sensors[0].filter_gain < 0.05
    assert measured["one_step_rmse_K"][0] == pytest.approx(measured["open_loop_rmse_K"][0], rel=0.05)


@pytest.mark.parametrize("target", ["ch3_um", "ch5_um"])
def test_fit_lumped_beats_no_compensation_held_out_on_fl_thermal_and_its_block_verifies(target, tmp_path):
    """Fit on the first 24 h, predict 22 h (open loop it was 61.8 um on ch3 against 30.9 with no
    compensation); the block with the filter gains replays the recording bit for bit."""
    fitted = thermoplc("fit", "--data", FL_THERMAL, "--model", "lumped", "--temps", "t5_C,t4_C", "--ambient", "t6_C",
                       "--speed", "spindle_rpm", "--target", target, "--train-until", 86400, "-o", "m.json", cwd=tmp_path)
    assert "filter gain (share of the reading taken each call): t5_C" in fitted.stdout
    held_out = json.loads((tmp_path / "m.json").read_text())["metrics"]["held_out"]
    assert held_out["rmse_um"] < 0.5 * held_out["zero_rmse_um"], held_out
    thermoplc("generate", "m.json", "-o", "m.scl", cwd=tmp_path)
    assert "c_KF_1" in (tmp_path / "m.scl").read_text()
    verified = thermoplc("verify", "m.scl", "--model", "m.json", "--data", FL_THERMAL, cwd=tmp_path)
    assert "bit-exact" in verified.stdout


def test_diagnose_starts_from_the_identified_model_and_beats_no_compensation(tmp_path):
    """Issue 39 item 1: diagnose's baseline is the model `fit --model lumped` identifies (given with --baseline
    or identified by diagnose itself, the same); on FL_THERMAL's 24 h training part its held-out error of ch5
    is below no compensation (the open-loop simulation diagnose judged before: worse than none on ch3), and the
    diagnosed model's block verifies bit-exact."""
    columns = ("--temps", "t5_C,t4_C", "--ambient", "t6_C", "--speed", "spindle_rpm", "--target", "ch5_um")
    thermoplc("fit", "--data", FL_THERMAL, "--model", "lumped", *columns, "--train-until", 86400, "-o", "base.json",
              cwd=tmp_path)
    from thermoplc.recordings.table import read_table
    table = read_table(FL_THERMAL)
    train = table.columns["time_s"] <= 86400
    target = table.columns["ch5_um"]
    training_mean = float(np.sqrt(np.mean((target[~train] - target[train].mean()) ** 2)))  # 10.38 um
    for given in (("--baseline", "base.json"), ()):
        thermoplc("diagnose", "--data", FL_THERMAL, *columns, *given, "--train-until", 86400, "--json", "f.json",
                  "-o", "d.json", "--force", cwd=tmp_path)
        findings = json.loads((tmp_path / "f.json").read_text())
        zero = json.loads((tmp_path / "base.json").read_text())["metrics"]["held_out"]["zero_rmse_um"]
        assert findings["rmse_before_um"] < min(zero, training_mean), (findings["rmse_before_um"], zero, training_mean)
        assert "KF_1" in json.loads((tmp_path / "d.json").read_text())["coefficients"]
    thermoplc("generate", "d.json", "-o", "d.scl", cwd=tmp_path)
    assert "bit-exact" in thermoplc("verify", "d.scl", "--model", "d.json", "--data", FL_THERMAL, cwd=tmp_path).stdout


def test_verify_refuses_a_block_with_a_filter_the_model_lacks(tmp_path):
    """A block constant the model has no counterpart for is a computation the model lacks, even
    where the replayed data cannot tell (a gain so small its correction rounds away)."""
    from tests.golden_models import GOLDEN
    model = json.loads((GOLDEN / "lumped_identified.json").read_text())
    for name in [n for n in model["coefficients"] if n.startswith("KF_")]:
        del model["coefficients"][name]
    (tmp_path / "open_loop.json").write_text(json.dumps(model))
    thermoplc("twin", "--hours", 12, "--seed", 7, "-o", "twin.csv", cwd=tmp_path)
    block = GOLDEN / "lumped_identified.tia.scl"
    result = thermoplc("verify", block, "--model", "open_loop.json", "--data", "twin.csv", cwd=tmp_path, check=1)
    assert "c_KF_1: declared in the block, but the model has no such constant" in result.stdout


def test_fit_lumped_refuses_a_flat_sensor_and_the_ambient_as_a_sensor_and_takes_twin_sensors(tmp_path):
    import csv
    rows = list(csv.reader(FL_THERMAL.open()))[:3000]
    header = rows[0]
    t5, t4 = header.index("t5_C"), header.index("t4_C")
    flat = [header] + [[*r[:t5], "30.0", *r[t5 + 1:]] for r in rows[1:]]
    twin = [header] + [[*r[:t5], r[t4], *r[t5 + 1:]] for r in rows[1:]]
    for name, table in (("flat.csv", flat), ("twin.csv", twin)):
        (tmp_path / name).write_text("\n".join(",".join(r) for r in table) + "\n")
    args = ("--model", "lumped", "--ambient", "t6_C", "--speed", "spindle_rpm", "--target", "ch3_um",
            "--train-until", 30000, "-o")
    refused = thermoplc("fit", "--data", "flat.csv", "--temps", "t5_C,t4_C", *args, "a.json", cwd=tmp_path, check=2)
    assert "t5_C does not change on the training rows" in refused.stderr
    refused = thermoplc("fit", "--data", FL_THERMAL, "--temps", "t5_C,t6_C", *args, "b.json", cwd=tmp_path, check=2)
    assert "--ambient t6_C: the column is also in --temps" in refused.stderr
    thermoplc("fit", "--data", "twin.csv", "--temps", "t5_C,t4_C", *args, "c.json", cwd=tmp_path)  # ridge, no singular solve
    assert not (tmp_path / "a.json").exists() and not (tmp_path / "b.json").exists()
