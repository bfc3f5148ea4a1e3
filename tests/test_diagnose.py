"""Finding the missing effect: each effect hidden in a machine's data is named, and nothing else.

Both synthetic machines (the cascade twin and the portal machine, written apart), with effect
parameters drawn at random from plausible ranges. "The gap falls by at least half" is checked on
the model error above the noise (sqrt(RMSE^2 - noise^2) of the channel that was off most): the
noise itself cannot be explained away.
"""
from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

from thermoplc.cli import main
from thermoplc.diagnosis.judges import BIC_MARGIN
from thermoplc.diagnosis.search import diagnose
from thermoplc.diagnosis.windows import noise_sigma
from thermoplc.machines import MACHINES, machine
from thermoplc.machines.random_effects import draw
from thermoplc.models.kinds import lumped_model
from thermoplc.physics import primitives
from thermoplc.physics import simulation
from thermoplc.physics.effects import NAMES, Effect
from thermoplc.models.modelfile import load_model
from thermoplc.models.reference import model_inputs, predict
from thermoplc.recordings.table import read_table
from thermoplc.machines.cascade import simulate

HOURS = 72
TEMPS = ("T_motor", "T_bearing")
TRAIN_SHARE = 0.6


LOOK_ALIKE = ("slow_structure", "ambient_coupling")


def _series(columns: dict, temps: tuple[str, ...] = TEMPS) -> simulation.Series:
    return simulation.Series(10.0, columns["time_s"], columns["n_rpm"], columns["T_env"],
                             np.column_stack([columns[c] for c in temps]), temps, columns["E_z_um"],
                             columns["v_feed_mm_min"])


def _run(effects: tuple[str, ...], seed: int = 5):
    columns = simulate(HOURS, seed, effects=tuple(Effect.parse(e) for e in effects))
    series = _series(columns)
    return diagnose(series, int(TRAIN_SHARE * series.rows), "E_z_um")


def _excess(rmse: float, sigma: float) -> float:
    return math.sqrt(max(rmse ** 2 - sigma ** 2, 0.0))


def _hidden(machine_name: str, name: str, seed: int, hours: float = HOURS):
    """Diagnosis of `name` hidden with parameters drawn for this machine and seed (the benchmark's draw)."""
    chosen = machine(machine_name)
    clean = chosen.simulate(hours, seed)
    rows = int(TRAIN_SHARE * len(clean["time_s"]))
    effect = draw(name, chosen, clean, rows, seed)
    columns = chosen.simulate(hours, seed, effects=(effect,))
    return diagnose(_series(columns, chosen.DIAGNOSED), rows, "E_z_um"), effect


# issue 39: measured on the identified baseline (filter gains, least-squares map), seed 1; left open in its note.
# Issue 51's bounded structure lag names the feed heat (both machines) and the portal's slow structure alone
_IDENTIFIED_SHORT = {
    ("portal", "gear_ratio_switch"): "nothing is named: the held-out evidence of the switch at 730 rpm falls short",
    ("portal", "ambient_coupling"): "the slow structure is named for the lagged ambient",
}


def _case(m: str, n: str):
    if (m, n) in _IDENTIFIED_SHORT:
        return pytest.param(m, n, marks=pytest.mark.xfail(strict=True, reason="known, issue 39: "
                                                                             + _IDENTIFIED_SHORT[m, n]))
    return pytest.param(m, n)


@pytest.mark.slow
@pytest.mark.parametrize("machine_name, name", [_case(m, n) for m in MACHINES for n in NAMES])
def test_a_hidden_effect_with_random_parameters_is_named_alone_and_the_gap_halves(machine_name, name):
    d, effect = _hidden(machine_name, name, seed=1)
    if name == "sensor_offset":  # the same column as the standstill heat load the baseline fits
        assert "sensor_offset" in d.not_tested and "sensor_offset" not in [e["name"] for e in d.named]
        return
    if d.ambiguous:  # lagged ambient and a slow structure can fit alike: then neither may be named
        assert {name, *(a.split()[0] for a in d.ambiguous)} == set(LOOK_ALIKE) and not d.added, (effect, d.ambiguous)
        assert d.verdict == "unexplained" and "cannot tell" in d.reason
        return
    assert [e["name"] for e in d.added] == [name], (effect, d.added)
    # the gap where the physics and the data disagree (the temperatures open loop, the displacement): the
    # filter's innovations stay white with a missing heat, so their own noise estimate takes the gap in
    n = d.parts.n_train
    rms = lambda x: float(np.sqrt(np.mean(x ** 2)))
    gap = lambda residual, c: _excess(rms(residual[c][:n]), noise_sigma(d.residual_before[c]))
    channel = max(d.channels, key=lambda c: gap(d.residual_before, c) / max(noise_sigma(d.residual_before[c]), 1e-12))
    before, after = gap(d.residual_before, channel), gap(d.residual_after, channel)
    assert after <= 0.5 * before, (effect, channel, before, after)
    # held out the gap falls too, though not always by half: a gear threshold drawn between two
    # training speeds stays uncertain where the held-out part runs between them
    assert rms(d.residual_after[channel][n:]) < rms(d.residual_before[channel][n:])


@pytest.mark.parametrize("machine_name", MACHINES)
def test_clean_data_of_either_machine_reads_no_missing_effect(machine_name):
    chosen = machine(machine_name)
    columns = chosen.simulate(HOURS, 1)
    d = diagnose(_series(columns, chosen.DIAGNOSED), int(TRAIN_SHARE * len(columns["time_s"])), "E_z_um")
    assert d.verdict == "no_missing_effect" and d.added == []


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_data_inside_paper_000s_class_with_random_parameters_reads_clean(seed):
    """Temperatures from the lumped-mass model driven by speed and ambient, displacement regressed on
    them through a structure lag: any parameters, three sensors, a schedule of its own."""
    rng = np.random.default_rng(seed)
    dt, rows = 10.0, 72 * 360 + 1
    t = np.arange(rows) * dt
    n = np.zeros(rows)
    j = int(rng.integers(30, 120))
    while j < rows:
        length = int(rng.integers(60, 1500))
        n[j:j + length] = rng.choice([0.0, rng.uniform(100, 5000)])
        j += length
    te = 18.0 + np.cumsum(rng.normal(0, 0.01, rows)) + rng.uniform(0.5, 2) * np.sin(2 * np.pi * t / 86400)
    sensors = tuple(simulation.SensorParams(tau_s=float(rng.uniform(900, 7200)), gain=float(rng.uniform(1e-3, 5e-3)))
                    for _ in range(3))
    k = len(sensors)
    displacement = primitives.DisplacementParams(
        tau_struct_s=float(rng.uniform(1, 6) * 3600), beta0=0.0, beta=tuple(rng.uniform(-4, 4, k)),
        gamma=tuple(rng.uniform(-6, 6, k)))
    truth = simulation.Simulation((), simulation.Shared(stopped_rpm=1.0), sensors, displacement)
    names = ("T_a", "T_b", "T_c")
    start = np.full((rows, k), te[0])
    series = simulation.Series(dt, t, n, te, start, names, np.zeros(rows))
    out = simulation.run(truth, series)
    temps = np.column_stack([out[c] for c in names]) + rng.normal(0, 0.05, (rows, k))
    target = out["target"] + rng.normal(0, 0.5, rows)
    measured = simulation.Series(dt, t, n, te + rng.normal(0, 0.05, rows), temps, names, target)
    d = diagnose(measured, int(TRAIN_SHARE * rows), "E")
    assert d.verdict == "no_missing_effect", (d.added, d.windows_before)


@pytest.mark.parametrize("hours, reason", [(8, "training part covers 4.8 h"), (72, "spindle runs 0.00 h")])
def test_data_that_cannot_decide_says_so(hours, reason):
    columns = machine("portal").simulate(hours, 2, effects=(Effect.parse("ambient_coupling"),))
    if hours == 72:
        columns["n_rpm"] = np.zeros_like(columns["n_rpm"])
    series = _series(columns, machine("portal").DIAGNOSED)
    d = diagnose(series, int(TRAIN_SHARE * series.rows), "E_z_um")
    assert d.verdict == "insufficient_data" and reason in d.reason
    assert d.added == []


def test_one_speed_leaves_the_speed_effects_untested():
    columns = simulate(HOURS, 5, constant_rpm=1500.0, effects=(Effect.parse("gear_ratio_switch"),))
    d = diagnose(_series(columns), int(TRAIN_SHARE * len(columns["time_s"])), "E_z_um")
    assert "gear_ratio_switch" in d.not_tested and "nonlinear_speed_heat" in d.not_tested
    assert d.added == []


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="known, issue 39: on the identified baseline the gear switch beside a drift "
                                       "is not named (the drift is)")
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


@pytest.mark.slow
@pytest.mark.parametrize("pair", [("gear_ratio_switch", "ambient_coupling"), pytest.param(
    ("sensor_drift", "stop_convection"), marks=pytest.mark.xfail(strict=True, reason=(
        "known, issue 39: on the identified baseline a lagged ambient is named for the drift beside the "
        "standstill change")))])
def test_two_hidden_effects_are_both_named(pair):
    d = _run(pair, seed=8)
    assert d.verdict == "explained"
    assert sorted(e["name"] for e in d.added) == sorted(pair)


@pytest.mark.slow
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


@pytest.mark.slow
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
    from thermoplc.models.model import Model, Signal
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
    for effect in findings["effects"]:  # issue 39 item 3: each named effect's size against the misfit left
        size = effect["evidence"]["held_out_size_um"]
        # a heat the filter already followed moves the target little: its share may be a hair below 0
        assert size > 0 and -0.05 < effect["evidence"]["held_out_error_removed"] <= 1
        assert effect["matters"] == ("above the misfit" if size >= findings["rmse_after_um"] else "below the misfit")
    assert "held out: moves the target" in capsys.readouterr().out
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


@pytest.mark.slow
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
    (["twin", "--hours", "1", "--effect", "slow_structure:tau_h=0", "-o", "x.csv"], "tau_h must be above 0"),
    (["twin", "--hours", "1", "--effect", "gear_ratio_switch:ratio=nan", "-o", "x.csv"], "ratio must be a finite"),
    (["twin", "--hours", "nan", "-o", "x.csv"], "argument --hours: expected hours from 0.001 to 1e+06, found nan"),
    (["twin", "--hours", "1", "--ambient-swing", "-1", "-o", "x.csv"], "argument --ambient-swing: expected kelvin from 0"),
    (["diagnose", "--data", "d.csv", "--speed", "n_rpm", "--ambient", "T_env", "--temps", "T_motor",
      "--target", "E_z_um", "-o", "d.csv"], "is also an input of this command"),
    (["diagnose", "--data", "d.csv", "--speed", "n_rpm", "--ambient", "T_env", "--temps", "T_motor",
      "--target", "E_z_um", "-o", "m.json", "--json", "m.json"], "m.json: named for both -o and --json"),
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
    try:
        code = main(args)
    except SystemExit as exc:  # argparse refuses an option value before any command runs
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "x.csv").exists()


def test_twin_machine_portal_from_the_cli(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["twin", "--machine", "portal", "--hours", "6", "--seed", "2", "--effect", "sensor_offset",
                 "-o", "p.csv"]) == 0
    out = capsys.readouterr().out
    assert "machine portal" in out and "hidden effect sensor_offset: column=T_column" in out
    table = read_table(tmp_path / "p.csv")
    assert {"T_spindle", "T_gearbox", "T_column", "E_z_um", "v_feed_mm_min"} <= set(table.columns)
    assert main(["twin", "--machine", "portal", "--hours", "6", "--sensor-fault", "offset:T_motor", "-o", "q.csv"]) == 2
    assert "COLUMN one of T_spindle, T_gearbox, T_column" in capsys.readouterr().err
    assert not (tmp_path / "q.csv").exists()


def test_an_effect_the_held_out_part_does_not_support_is_listed_with_its_size_not_dropped(tmp_path):
    """Issue 39 item 3: a 6 h lag of the air in the displacement of the training part only: the training part
    supports a lag of the air (BIC), the held-out part does not; it is listed beside the verdict with its
    evidence, never named. (A 3 h lag lies inside the baseline's own structure lags, 10 min to 4 h since issue 51:
    the structure takes most of it and the lag of the air left over fits at the edge of its range.)"""
    columns = simulate(48, 5)
    hours = (columns["time_s"] - columns["time_s"][0]) / 3600
    n_train = int(0.6 * len(hours))
    air = columns["T_env"] - columns["T_env"][0]
    pole = math.exp(-10.0 / (6 * 3600))
    lagged = np.array(list(itertools.accumulate(air, lambda y, x: pole * y + (1 - pole) * x, initial=0.0))[1:])
    columns["E_z_um"] = columns["E_z_um"] + np.where(hours < hours[n_train], 4.0 * lagged, 0.0)
    series = _series(columns)
    d = diagnose(series, n_train, "E_z_um")
    assert d.named == [] and [e["name"] for e in d.unsupported] == ["ambient_coupling"]
    entry = d.unsupported[0]
    assert entry["evidence"]["delta_bic"] < -BIC_MARGIN and entry["evidence"]["held_out_size_um"] > 0
    assert entry["matters"] in ("above the misfit", "below the misfit")
    assert entry["why_not_named"].startswith("the held-out part does not support it: log-likelihood evidence")
    from thermoplc.diagnosis.findings import document, text
    doc = document(d, {"file": "x.csv", "sha256": "0"}, None)
    assert doc["supported_not_named"] == d.unsupported
    assert "  not named: ambient_coupling (delta BIC" in text(doc)
    from thermoplc.diagnosis.report import report
    page = report(doc, d)["index.html"]
    assert "Supported by the training part, not by the held-out part" in page and "ambient_coupling" in page


DIAGNOSE_TWIN = ["--speed", "n_rpm", "--ambient", "T_env", "--temps", "T_motor,T_bearing", "--target", "E_z_um"]


@pytest.mark.slow
def test_the_clean_recordings_model_as_baseline_names_the_injected_effect_and_nothing_on_clean_data(
        tmp_path, monkeypatch):
    """Issue 51 item 2, as held-out code runs it: diagnose the clean recording, then the same machine with an
    effect added, judged on top of the clean diagnosis (--baseline); the clean recording judged on its own
    diagnosed model names nothing new."""
    monkeypatch.chdir(tmp_path)
    assert main(["twin", "--hours", "48", "--seed", "5", "-o", "clean.csv"]) == 0
    assert main(["twin", "--hours", "48", "--seed", "5", "--effect", "gear_ratio_switch:threshold_rpm=750",
                 "-o", "injected.csv"]) == 0
    assert main(["diagnose", "--data", "clean.csv", *DIAGNOSE_TWIN, "-o", "clean_model.json"]) == 0
    for data, named in (("injected.csv", ["gear_ratio_switch"]), ("clean.csv", [])):
        assert main(["diagnose", "--data", data, *DIAGNOSE_TWIN, "--baseline", "clean_model.json",
                     "--json", f"{data}.json", "-o", f"{data}_model.json"]) == 0
        findings = json.loads((tmp_path / f"{data}.json").read_text())
        assert [e["name"] for e in findings["effects"]] == named, findings["summary"]


def test_a_baseline_worse_than_no_compensation_names_nothing_and_says_so():
    """Issue 51 item 3: a baseline that predicts the held-out target no better than no compensation is no ground
    to judge effects on: its disagreement there is its own extrapolation."""
    from thermoplc.diagnosis import sufficiency
    assert sufficiency.worse_than_none(7.65, 24.92) is None
    why = sufficiency.worse_than_none(24.96, 24.92)
    assert "no better than no compensation (RMSE 24.96 against 24.92 um)" in why and "no effect is judged" in why
    assert sufficiency.worse_than_none(24.96, None) is None and sufficiency.worse_than_none(None, 3.0) is None


@pytest.mark.slow
@pytest.mark.parametrize("channel", ["ch3_um", "ch5_um"])
def test_fl_thermal_baseline_beats_no_compensation_on_every_training_part(channel):
    """Issue 51 items 1 and 3 on real data: diagnose's baseline predicts FL_THERMAL's held-out target better than
    no compensation for every training part of 40-75 % (the 48 h structure-lag grid gave 24.96 um against 24.92
    on ch3 at 60 %, and 22.62 against 24.44 on ch5 at 45 %); whatever it names lowers the held-out error."""
    from thermoplc.demo import recording
    from thermoplc.diagnosis import sufficiency
    from thermoplc.diagnosis.parts import single
    from thermoplc.physics.primitives import Series
    from thermoplc.recordings.table import read_table
    columns = read_table(recording()).columns
    series = Series(15.0, columns["time_s"], columns["spindle_rpm"], columns["t6_C"],
                    np.column_stack([columns["t5_C"], columns["t4_C"]]), ("t5_C", "t4_C"), columns[channel], None)
    for share in (0.40, 0.45, 0.50, 0.55, 0.60, 0.65, 0.70, 0.75):
        rows = int(round(share * series.rows))
        d = diagnose(series, rows, channel)
        none = sufficiency.no_compensation_rmse(single(series, rows))
        assert d.before.rmse_held_out[channel] < 0.8 * none, (share, d.before.rmse_held_out[channel], none)
        assert d.after.rmse_held_out[channel] <= d.before.rmse_held_out[channel]
        assert all(e["evidence"]["held_out_evidence"] > 0 for e in d.named), (share, d.named)


@pytest.mark.slow
def test_a_cooling_with_a_lag_of_its_own_is_named_with_its_lag_and_the_block_carries_it(tmp_path, monkeypatch):
    """Issue 65 item 2: the coolant's cooling reaches the motor through 30 min of its own (the coolant loop's
    thermal mass). The relay is named alone with a lag near it and its thresholds near the hidden 27/24 degC,
    nothing is left unexplained, and the motor's held-out open-loop error falls to its noise, a quarter of what
    the relay at once leaves (0.203 K on this recording, measured with the lag grid cut to none); the block
    carrying the lag (LC) is generated and proved bit-exact."""
    monkeypatch.chdir(tmp_path)
    assert main(["twin", "--hours", "72", "--seed", "5", "--effect", "coolant_switching:lag_min=30",
                 "-o", "lag.csv"]) == 0
    assert main(["diagnose", "--data", "lag.csv", "--speed", "n_rpm", "--ambient", "T_env", "--temps",
                 ",".join(TEMPS), "--target", "E_z_um", "--json", "f.json", "-o", "m.json"]) == 0
    findings = json.loads((tmp_path / "f.json").read_text())
    assert [e["name"] for e in findings["effects"]] == ["coolant_switching"]
    parameters = findings["effects"][0]["parameters"]
    assert 25 <= parameters["lag_min"] <= 35 and abs(parameters["on_C"] - 27) < 0.3 and abs(parameters["off_C"] - 24) < 0.4
    assert findings["verdict"] == "explained"
    motor = findings["channels"]["T_motor"]
    assert motor["open_loop_held_out_rmse_after"] < 0.3 * 0.203 < motor["open_loop_held_out_rmse_before"]
    assert main(["generate", "m.json", "-o", "m.scl", "--accept-unvalidated"]) == 0
    assert "#LC := #c_ACl * #LC + #c_BCl;" in (tmp_path / "m.scl").read_text()
    assert main(["verify", "m.scl", "--model", "m.json", "--data", "lag.csv"]) == 0
