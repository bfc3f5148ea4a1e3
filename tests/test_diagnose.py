"""Finding the missing effect: each effect hidden in twin data is named, and nothing else.

"The held-out RMSE falls by at least half" is checked on the model error above the noise
(sqrt(RMSE^2 - noise^2) of the channel the effect shows in): the noise itself cannot be
explained away, so raw RMSE cannot halve for an effect the size of the noise.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from thermoplc.cli import main
from thermoplc.diagnosis.search import diagnose
from thermoplc.models import lumped_model, simulation
from thermoplc.models.effects import NAMES, SHOWS_IN, Effect
from thermoplc.models.modelfile import load_model
from thermoplc.models.reference import model_inputs, predict
from thermoplc.models.table import read_table
from thermoplc.machines.cascade import simulate

HOURS = 72
TEMPS = ("T_motor", "T_bearing")
# where each effect shows: a temperature channel or the displacement

def _series(columns: dict) -> simulation.Series:
    return simulation.Series(10.0, columns["time_s"], columns["n_rpm"], columns["T_env"],
                             np.column_stack([columns[c] for c in TEMPS]), TEMPS, columns["E_z_um"],
                             columns["v_feed_mm_min"])


def _run(effects: tuple[str, ...], seed: int = 5):
    columns = simulate(HOURS, seed, effects=tuple(Effect.parse(e) for e in effects))
    series = _series(columns)
    return diagnose(series, int(0.6 * series.rows), "E_z_um")


def _excess(rmse: float, sigma: float) -> float:
    return math.sqrt(max(rmse ** 2 - sigma ** 2, 0.0))


def test_every_effect_has_a_twin_switch_and_a_shown_channel():
    assert set(SHOWS_IN) == set(NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_a_hidden_effect_is_named_alone_and_the_gap_halves(name):
    d = _run((name,))
    assert d.verdict == "explained", d.windows_after
    assert [e["name"] for e in d.added] == [name]
    channel = SHOWS_IN[name]
    before = _excess(d.before.rmse_held_out[channel], d.sigma[channel])
    after = _excess(d.after.rmse_held_out[channel], d.sigma[channel])
    assert after <= 0.5 * before, (before, after)


def test_fitted_parameters_are_the_hidden_ones():
    d = _run(("gear_ratio_switch", "sensor_drift:column=T_bearing,rate_K_per_h=0.08"))
    found = {e["name"]: e["parameters"] for e in d.added}
    assert found["gear_ratio_switch"]["threshold_rpm"] == 750.0
    assert found["gear_ratio_switch"]["heat_ratio_above"]["T_motor"] == pytest.approx(1.6, rel=0.02)
    assert found["sensor_drift"]["column"] == "T_bearing"
    assert found["sensor_drift"]["rate_K_per_h"] == pytest.approx(0.08, rel=0.05)


def test_no_hidden_effect_means_no_missing_effect():
    d = _run(())
    assert d.verdict == "no_missing_effect"
    assert d.added == [] and d.windows_before == []


@pytest.mark.parametrize("pair", [("gear_ratio_switch", "ambient_coupling"), ("sensor_offset", "stop_convection")])
def test_two_hidden_effects_are_both_named(pair):
    d = _run(pair, seed=8)
    assert d.verdict == "explained"
    assert sorted(e["name"] for e in d.added) == sorted(pair)


def test_an_effect_outside_the_library_stays_unexplained():
    """Heat that steps up at a fixed time (a neighbouring machine switched on) is no named effect."""
    columns = simulate(HOURS, 5)
    t = columns["time_s"]
    columns["T_motor"] = columns["T_motor"] + np.where((t > 30 * 3600) & (t < 36 * 3600), 1.5, 0.0)
    columns["E_z_um"] = columns["E_z_um"] + np.where(t > 50 * 3600, 6.0, 0.0)
    series = _series(columns)
    d = diagnose(series, int(0.6 * series.rows), "E_z_um")
    assert d.verdict == "unexplained"
    assert d.windows_after


def test_the_lumped_reference_is_the_simulation():
    """The model file's float64 reference replays exactly what the diagnosis simulated."""
    columns = simulate(24, 3, effects=(Effect.parse("nonlinear_speed_heat"), Effect.parse("coolant_switching")))
    series = _series(columns)
    effects = (("nonlinear_speed_heat", None), ("coolant_switching", 0), ("stop_convection", None),
               ("slow_structure", None), ("ambient_coupling", None), ("feed_axis_heat", None), ("sensor_offset", 1))
    fitted = simulation.fit(series.head(5000), effects)
    coefficients, settings = lumped_model.coefficients(fitted, 10.0)
    again = lumped_model.simulation_of(_model(coefficients, settings))
    expected = simulation.run(fitted, series)["target"]
    assert np.max(np.abs(simulation.run(again, series)["target"] - expected)) < 1e-9
    model = _model(coefficients, settings)
    inputs = {"T_motor": columns["T_motor"], "T_bearing": columns["T_bearing"], "n_rpm": columns["n_rpm"],
              "T_env": columns["T_env"], "v_feed": columns["v_feed_mm_min"]}
    assert np.max(np.abs(predict(model, inputs, "f64")["E_z_um"] - expected)) < 1e-8


def _model(coefficients, settings):
    from thermoplc.models.modelfile import Model, Signal
    inputs = (Signal("T_motor", "T_motor", "temperature", "degC"), Signal("T_bearing", "T_bearing", "temperature", "degC"),
              Signal("n_rpm", "n_rpm", "speed", "rpm"), Signal("T_env", "T_env", "ambient", "degC"),
              Signal("v_feed", "v_feed_mm_min", "feed", "mm/min"))
    return Model("lumped", "ThermalComp", inputs, Signal("E_z_um", "E_z_um", "target", "um"), "time_s", 10.0,
                 coefficients, settings)


def test_diagnose_cli_end_to_end(tmp_path, monkeypatch, capsys):
    """As a user types it: twin with a hidden effect, diagnose, generate, verify bit-exact."""
    monkeypatch.chdir(tmp_path)
    assert main(["twin", "--hours", "48", "--seed", "5", "--effect", "gear_ratio_switch:threshold_rpm=750",
                 "--effect", "feed_axis_heat", "-o", "hidden.csv"]) == 0
    assert main(["diagnose", "--data", "hidden.csv", "--speed", "n_rpm", "--ambient", "T_env", "--temps",
                 "T_motor,T_bearing", "--target", "E_z_um", "--feed", "v_feed_mm_min", "--json", "findings.json",
                 "--report", "diag", "-o", "aug.json"]) == 0
    findings = json.loads((tmp_path / "findings.json").read_text())
    assert findings["verdict"] == "explained"
    assert sorted(e["name"] for e in findings["effects"]) == ["feed_axis_heat", "gear_ratio_switch"]
    assert findings["rmse_after_um"] < findings["rmse_before_um"]
    assert all({"start_s", "end_s", "channel", "rms", "conditions"} <= set(w) for w in findings["disagreements"])
    page = (tmp_path / "diag" / "index.html").read_text()
    assert "gear_ratio_switch" in page and 'src="channel_3.png"' in page
    assert (tmp_path / "diag" / "channel_3.png").read_bytes()[:4] == b"\x89PNG"
    assert main(["generate", "aug.json", "-o", "aug.scl"]) == 0
    assert main(["verify", "aug.scl", "--model", "aug.json", "--data", "hidden.csv"]) == 0
    assert "every bit equal" in capsys.readouterr().out
    model = load_model(tmp_path / "aug.json")
    assert [s.role for s in model.inputs][-1] == "feed"
    table = read_table(tmp_path / "hidden.csv")
    block = predict(model, model_inputs(model, table), "f32")["E_z_um"]
    assert block.dtype == np.float32


def test_diagnose_is_deterministic(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["twin", "--hours", "24", "--seed", "2", "--effect", "sensor_offset", "-o", "d.csv"]) == 0
    args = ["diagnose", "--data", "d.csv", "--speed", "n_rpm", "--ambient", "T_env", "--temps", "T_motor,T_bearing",
            "--target", "E_z_um", "--json"]
    assert main(args + ["a.json", "-o", "ma.json"]) == 0
    assert main(args + ["b.json", "-o", "mb.json"]) == 0
    assert (tmp_path / "a.json").read_text().replace("ma.json", "") == (tmp_path / "b.json").read_text().replace("mb.json", "")
    assert (tmp_path / "ma.json").read_bytes() == (tmp_path / "mb.json").read_bytes()


@pytest.mark.parametrize("args, message", [
    (["twin", "--hours", "1", "--effect", "gravity", "-o", "x.csv"], "unknown effect 'gravity'"),
    (["twin", "--hours", "1", "--effect", "gear_ratio_switch:speed=3", "-o", "x.csv"], "keys threshold_rpm, ratio"),
    (["twin", "--hours", "1", "--effect", "sensor_offset:column=T_nope", "-o", "x.csv"], "column must be one of"),
    (["diagnose", "--data", "d.csv", "--speed", "n_rpm", "--ambient", "T_env", "--temps", "T_motor",
      "--target", "E_z_um", "--baseline", "mlr.json"], "needs a lumped model"),
    (["diagnose", "--data", "d.csv", "--speed", "n_rpm", "--ambient", "T_env", "--temps", "T_nope",
      "--target", "E_z_um"], "no column 'T_nope'"),
])
def test_bad_diagnose_input_is_a_clear_error(tmp_path, monkeypatch, capsys, args, message):
    monkeypatch.chdir(tmp_path)
    assert main(["twin", "--hours", "6", "--seed", "1", "-o", "d.csv"]) == 0
    assert main(["fit", "--data", "d.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor",
                 "--train-rows", "1000", "-o", "mlr.json"]) == 0
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "x.csv").exists()
