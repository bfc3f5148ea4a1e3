"""Issue 61, item 4: a temperature that drifts away from what the others say it should read sets SensorsDisagree
(models/plausibility.py), and the block holds its outputs as for a fault bit."""
from __future__ import annotations

import json
import re
from dataclasses import replace

import numpy as np
import pytest

from thermoplc.base import compiled
from thermoplc.base.errors import UserError
from thermoplc.models.modelfile import load_model
from thermoplc.models.plausibility import DISAGREE, CheckState, Plausibility, disagree
from thermoplc.models.reference import block_outputs, model_inputs
from thermoplc.models.safety import Limits
from thermoplc.models.streaming import StreamingReference
from thermoplc.recordings.table import read_table
from thermoplc.verifier.replays.restarts import restart_cases
from tests.cli_runner import thermoplc
from tests.golden_models import GOLDEN, golden_twin_csv

# x2 should read 1 + 0.5 * x1 within 2 K (quiet inside 1 K); x1 should read -2 + 2 * x2 within 4 K
CHECK = Plausibility.of([("x1", -2.0, [("x2", 2.0)], 4.0, 1.0), ("x2", 1.0, [("x1", 0.5)], 2.0, 0.5)])
# the same relations with the swing test: each difference may leave its 10-min mean by 1 K (quiet inside 0.5 K)
SWINGING = Plausibility.of([("x1", -2.0, [("x2", 2.0)], 4.0, 1.0, 1.0, 0.5), ("x2", 1.0, [("x1", 0.5)], 2.0, 0.5, 1.0, 0.5)])
PERIOD_S = 15.0


@pytest.mark.parametrize("reference", ["slow", "fast"])
def test_the_bit_latches_until_the_sensors_agree_for_the_settle_calls(reference):
    x1 = np.full(20, 10.0, np.float32)
    x2 = np.full(20, 6.0, np.float32)  # 1 + 0.5 * 10: agrees
    x2[5] = 8.5  # 2.5 K off: beyond the gate
    x2[6:9] = 7.5  # 1.5 K off: inside the gate, not quiet
    with compiled.reference(reference):
        flag = disagree(CHECK, {"x1": x1, "x2": x2}, 3, PERIOD_S, "f32")
    assert np.flatnonzero(flag).tolist() == list(range(5, 11))  # quiet from call 9; the third quiet call (11) clears


def test_a_nan_reading_is_never_quiet_and_never_beyond():
    x1, x2 = np.full(6, 10.0, np.float32), np.full(6, 6.0, np.float32)
    x2[1], x2[2:] = 9.0, np.nan
    assert disagree(CHECK, {"x1": x1, "x2": x2}, 2, PERIOD_S, "f32").tolist() == [False, True, True, True, True, True]


@pytest.mark.parametrize("check", [CHECK, SWINGING], ids=["level", "swing"])
def test_the_state_carries_from_one_chunk_to_the_next(check):
    rng = np.random.default_rng(5)
    x1 = (20 + rng.normal(0, 1, 300)).astype(np.float32)
    x2 = (1 + 0.5 * x1 + rng.normal(0, 1.2, 300)).astype(np.float32)
    whole = disagree(check, {"x1": x1, "x2": x2}, 4, PERIOD_S, "f32")
    state = CheckState(np.float32, 2)
    pieces = [disagree(check, {"x1": x1[a:a + 7], "x2": x2[a:a + 7]}, 4, PERIOD_S, "f32", state)
              for a in range(0, 300, 7)]
    assert whole.any() and np.array_equal(np.concatenate(pieces), whole)


def test_a_swing_inside_the_gate_sets_the_bit_and_a_slow_drift_of_the_same_size_does_not():
    calls = np.arange(2000)
    x1 = np.full(2000, 20.0, np.float32)
    x2 = np.full(2000, 11.0, np.float32)  # agrees: 1 + 0.5 * 20
    sine = (x2 + 1.5 * np.sin(calls * PERIOD_S / 350.0) * (calls >= 500)).astype(np.float32)  # 1.5 K: inside 2 K
    ramp = (x2 + np.linspace(0, 1.5, 2000)).astype(np.float32)  # the same 1.5 K over 8 h
    assert not disagree(CHECK, {"x1": x1, "x2": sine}, 30, PERIOD_S, "f32").any()  # the level test cannot see it
    flag = disagree(SWINGING, {"x1": x1, "x2": sine}, 30, PERIOD_S, "f32")
    assert not flag[:500].any() and flag[530:].all()  # seen within one eighth of the sine's period, and held
    assert not disagree(SWINGING, {"x1": x1, "x2": ramp}, 30, PERIOD_S, "f32").any()


@pytest.mark.parametrize("precision", ["f32", "f64"])
def test_the_swing_loop_is_the_same_compiled_and_as_python(precision):
    rng = np.random.default_rng(11)
    f = np.float32 if precision == "f32" else np.float64
    x1 = (25 + np.cumsum(rng.normal(0, 0.05, 3000))).astype(f)
    x2 = (1 + 0.5 * x1 + np.cumsum(rng.normal(0, 0.04, 3000))).astype(f)
    runs = {}
    for reference in ("slow", "fast"):
        with compiled.reference(reference):
            runs[reference] = disagree(SWINGING, {"x1": x1, "x2": x2}, 30, PERIOD_S, precision)
    assert runs["slow"].any() and not runs["slow"].all()
    assert np.array_equal(runs["slow"], runs["fast"])


@pytest.mark.parametrize("kind", ["mlr", "kalman"])
def test_the_golden_block_never_flags_its_own_recording_and_a_drifting_sensor_holds_it(tmp_path, kind):
    model = load_model(GOLDEN / f"{kind}.json")
    table = read_table(golden_twin_csv(tmp_path))
    inputs = model_inputs(model, table)
    limits = Limits.for_model(model)
    clean = block_outputs(model, inputs, "f32", limits)
    assert not clean[DISAGREE].any()
    drifting = dict(inputs)
    drifting["T_bearing"] = inputs["T_bearing"] + np.linspace(0, 6, table.rows, dtype=np.float32)  # 6 K in 12 h
    out = block_outputs(model, drifting, "f32", limits)
    first = int(np.argmax(out[DISAGREE]))
    assert out[DISAGREE][first:].all() and first > 0
    assert not any(np.asarray(out[f"fault:{s.name}"], bool).any() for s in model.inputs)  # no other bit sees it
    held = out["E_z_um"][first:].astype(np.float64)
    assert np.abs(held[-1]) < np.abs(clean["E_z_um"][-1]) / 2  # faded towards no compensation


def test_streamed_reference_carries_the_bit(tmp_path):
    model = load_model(GOLDEN / "mlr.json")
    table = read_table(golden_twin_csv(tmp_path))
    inputs = model_inputs(model, table)
    inputs["T_motor"] = inputs["T_motor"] + np.where(np.arange(table.rows) > 2000, np.float32(3), np.float32(0))
    limits = Limits.for_model(model)
    whole = block_outputs(model, inputs, "f32", limits)
    stream = StreamingReference(model, limits, "f32")
    pieces = [stream.step({k: v[a:a + 1000] for k, v in inputs.items()}) for a in range(0, table.rows, 1000)]
    assert whole[DISAGREE].any()
    for name, values in whole.items():
        assert np.concatenate([p[name] for p in pieces]).tobytes() == np.asarray(values).tobytes(), name


def test_verify_faults_counts_the_bit_and_fails_a_block_without_the_check(tmp_path):
    data = golden_twin_csv(tmp_path)
    thermoplc("generate", GOLDEN / "mlr.json", "-o", "m.scl", cwd=tmp_path)
    text = (tmp_path / "m.scl").read_text()
    assert "SensorsDisagree : Bool;" in text and "#FaultAny := #Fault_T_motor OR #Fault_T_bearing OR #SensorsDisagree;" in text
    faults = thermoplc("verify", "m.scl", "--model", GOLDEN / "mlr.json", "--data", data, "--faults", "--json", "-",
                       cwd=tmp_path)
    cases = {(c["sensor"], c["fault"]): c for c in json.loads(faults.stdout)["cases"]}
    assert cases[("T_bearing", "sine")]["flagged"] and cases[("T_bearing", "offset")]["flagged"]
    planted = text.replace("#SensorsDisagree := TRUE;", "#PlausQuiet := 0;")
    assert planted != text
    (tmp_path / "p.scl").write_text(planted)
    plain = thermoplc("verify", "p.scl", "--model", GOLDEN / "mlr.json", "--data", data, cwd=tmp_path)
    assert plain.returncode == 0  # the clean recording never sets the bit: only the fault cases tell
    failed = thermoplc("verify", "p.scl", "--model", GOLDEN / "mlr.json", "--data", data, "--faults", cwd=tmp_path,
                       check=1)
    assert "NOT bit-exact" in failed.stdout or "case(s) FAILED" in failed.stdout


def test_a_block_without_the_swing_test_passes_verify_and_fails_verify_faults(tmp_path):
    data = golden_twin_csv(tmp_path)
    thermoplc("generate", GOLDEN / "mlr.json", "-o", "m.scl", cwd=tmp_path)
    text = (tmp_path / "m.scl").read_text()
    planted = text  # each swing gate widened by the level gate: every constant as the model has it
    for k in (1, 2):
        planted = planted.replace(f"#PlausResid > #c_PlausSwing_{k} THEN",
                                  f"#PlausResid > #c_PlausSwing_{k} + #c_PlausGate_{k} THEN")
    assert planted.count("+ #c_PlausGate_") == 2
    (tmp_path / "p.scl").write_text(planted)
    thermoplc("verify", "p.scl", "--model", GOLDEN / "mlr.json", "--data", data, cwd=tmp_path)
    failed = thermoplc("verify", "p.scl", "--model", GOLDEN / "mlr.json", "--data", data, "--faults", cwd=tmp_path,
                       check=1)
    sine = next(line for line in failed.stdout.splitlines() if line.startswith("T_motor") and " sine: " in line)
    assert sine.split("degC")[-1].split()[0] == "NO"  # the sine is not bit-exact: the model flags it, the block not


def _started_too_late(text: str) -> str:
    """PlausStarted set after the first relation: the other relations' means never start at their difference."""
    text = text.replace("\n\t        #PlausStarted := TRUE;", "", 1)
    first = "\n\t        #PlausDev := #PlausDiff - #PlausMean_1;"
    return text.replace(first, "\n\t        #PlausStarted := TRUE;" + first, 1)


# hand edits that start the slow means wrong: each agrees with the model wherever the recording starts the block
STARTS_PLANTED = {
    "reset-keeps-started": lambda text: text.replace("\n\t        #PlausStarted := FALSE;", "", 1),
    "no-start-at-difference": lambda text: re.sub(r"\n\t *IF NOT #PlausStarted THEN\n\t *#PlausMean_\d+ := #PlausDiff;"
                                                  r"\n\t *END_IF;", "", text),
    "started-too-late": _started_too_late,
    "reset-keeps-the-mean": lambda text: re.sub(r"\n\t *#PlausMean_\d+ := #c_Zero;", "",
                                                text.replace("\n\t        #PlausStarted := FALSE;", "", 1)),
    "check-runs-while-disabled": lambda text: text.replace(
        "REGION Plausibility: each temperature against what the others say it should read\n\t    IF #Enable AND #Ready",
        "REGION Plausibility: each temperature against what the others say it should read\n\t    IF #Ready"),
}
# the case that tells each: a restart where the data moved (verifier/replays/restarts.py)
STARTS_TOLD_BY = {"check-runs-while-disabled": "/pause-flagged"}


@pytest.mark.parametrize("plant", STARTS_PLANTED)
def test_a_block_that_starts_its_slow_means_wrong_passes_verify_and_fails_verify_faults(tmp_path, plant):
    data = golden_twin_csv(tmp_path)
    thermoplc("generate", GOLDEN / "mlr.json", "-o", "m.scl", cwd=tmp_path)
    text = (tmp_path / "m.scl").read_text()
    planted = STARTS_PLANTED[plant](text)
    assert planted != text and "PlausStarted" in planted
    (tmp_path / "p.scl").write_text(planted)
    thermoplc("verify", "p.scl", "--model", GOLDEN / "mlr.json", "--data", data, cwd=tmp_path)
    failed = thermoplc("verify", "p.scl", "--model", GOLDEN / "mlr.json", "--data", data, "--faults", cwd=tmp_path,
                       check=1)
    verdict = next(line for line in failed.stdout.splitlines() if "case(s) FAILED" in line)
    assert STARTS_TOLD_BY.get(plant, "/reset-after") in verdict


def test_the_restart_cases_reset_where_the_difference_is_largest_and_every_input_in_range():
    model = load_model(GOLDEN / "mlr.json")
    rows = 400
    relation_1, relation_2 = model.plausibility.relations
    x1 = np.linspace(20, 30, rows).astype(np.float32)
    x2 = x1.copy()
    x2[300] = 3276.7  # an open circuit where the differences are largest: no restart may fall on it
    inputs = {relation_1.sensor: x1, relation_2.sensor: x2}
    limits = Limits.for_model(model)
    cases, not_run = restart_cases(model, inputs, [relation_1.sensor, relation_2.sensor], {"Enable", "Reset"}, limits,
                                   7)
    assert [c.name for c in cases] == ["reset-after", "reset-after", "reset-far", "reset-stuck", "pause",
                                       "pause-flagged", "pause-stuck", "late-start"] and not_run == []
    for case, relation in zip(cases, (relation_1, relation_2)):
        row = int(np.flatnonzero(case.control["Reset"])[0])
        assert row > case.first and row != 300 and np.flatnonzero(case.control["Reset"]).tolist() == [row]
        moved = case.columns[relation.sensor].astype(np.float64) - inputs[relation.sensor]
        assert np.all(moved[:case.first] == 0) and np.allclose(moved[case.first:row], 5.0, atol=1e-5)
        after = {name: values[row] for name, values in {**inputs, **case.columns}.items()}
        difference = after[relation.sensor] - relation.intercept[0] - sum(b[0] * after[name] for name, b in relation.slopes)
        # beyond the swing gate (a mean a Reset zeroes shows), inside the level gate (the level test hides nothing)
        assert relation.swing_K[0] < abs(difference) <= relation.gate_K[0]
    for case in cases:
        assert case.first != 300 and all(np.flatnonzero(v).tolist() != [300] for v in case.control.values())
    late = cases[-1]
    assert np.isnan(late.columns[relation_1.sensor][late.first:late.first + 5]).all()
    assert np.flatnonzero(late.control["Enable"])[0] == late.first


def test_a_model_file_from_before_the_swing_test_generates_without_it_and_verifies(tmp_path):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    for relation in doc["plausibility"]:
        del relation["swing_K"], relation["largest_swing_K"]
    (tmp_path / "m.json").write_text(json.dumps(doc))
    thermoplc("generate", "m.json", "-o", "m.scl", cwd=tmp_path)
    text = (tmp_path / "m.scl").read_text()
    assert "SensorsDisagree : Bool;" in text and "PlausMean" not in text and "c_PlausSwing" not in text
    thermoplc("verify", "m.scl", "--model", "m.json", "--data", golden_twin_csv(tmp_path), "--faults", cwd=tmp_path)


def test_a_model_file_from_before_the_swing_test_keeps_its_ambient_in_the_relations(tmp_path):
    doc = json.loads((GOLDEN / "lumped.json").read_text())  # as fitted before: every other temperature a slope
    zero, names = {"f64": 0.0, "f32": "0x00000000"}, ["T_motor", "T_bearing", "T_env"]
    for relation in doc["plausibility"]:
        del relation["swing_K"], relation["largest_swing_K"]
        relation["slopes"] = {name: relation["slopes"].get(name, zero) for name in names if name != relation["sensor"]}
        relation["gate_K"] = relation["gate_K"] or {"f64": 4.0, "f32": "0x40800000"}
        relation["largest_K"] = relation["largest_K"] or 1.0
    (tmp_path / "m.json").write_text(json.dumps(doc))
    model = load_model(tmp_path / "m.json")
    assert not model.plausibility.swings and len(model.plausibility.relations[2].slopes) == 2
    thermoplc("generate", "m.json", "-o", "m.scl", cwd=tmp_path)
    assert "c_PlausB_1_4" in (tmp_path / "m.scl").read_text()  # T_motor's relation takes T_env (input 4)


def test_a_model_file_without_the_check_has_no_bit_and_its_block_verifies(tmp_path):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    del doc["plausibility"]
    (tmp_path / "m.json").write_text(json.dumps(doc))
    thermoplc("generate", "m.json", "-o", "m.scl", cwd=tmp_path)
    assert "SensorsDisagree" not in (tmp_path / "m.scl").read_text()
    thermoplc("verify", "m.scl", "--model", "m.json", "--data", golden_twin_csv(tmp_path), cwd=tmp_path)


def test_an_input_named_like_the_status_bit_is_refused(tmp_path):
    table = (tmp_path / "d.csv")
    source = golden_twin_csv(tmp_path).read_text().splitlines()
    table.write_text("\n".join([source[0].replace("T_bearing", "SensorsDisagree"), *source[1:]]) + "\n")
    result = thermoplc("fit", "--data", "d.csv", "--model", "mlr", "--target", "E_z_um", "--temps",
                       "T_motor,SensorsDisagree", "--train-until", "21600", "-o", "m.json", cwd=tmp_path, check=2)
    assert "'SensorsDisagree' and 'SensorsDisagree' are the same identifier" in result.stderr
    assert not (tmp_path / "m.json").exists()


@pytest.mark.parametrize("edit, expected", [
    (lambda p: p.pop(), "field 'plausibility': expected a list of two or more relations"),
    (lambda p: p[0].update(sensor="T_env"), "field 'plausibility[0].sensor': 'T_env'; expected one of"),
    (lambda p: p[0].update(slopes={}), "field 'plausibility[0].slopes': expected one slope for each of T_bearing"),
    (lambda p: p[1]["gate_K"].update(f64=0.1, f32="0x3DCCCCCD"), "field 'plausibility[1].gate_K': 0.1; expected 0.5"),
    (lambda p: p[0].update(largest_K=99.0), "field 'plausibility[0].largest_K': 99.0; expected the largest"),
    (lambda p: p[0]["intercept"].update(f64=1e7, f32="0x4B189680"), "field 'plausibility[0].intercept': 10000000.0"),
    (lambda p: p[0].pop("gate_K"), "field 'plausibility[0]': expected an object with gate_K, intercept, largest_K"),
    (lambda p: p[1]["swing_K"].update(f64=0.2, f32="0x3E4CCCCD"), "field 'plausibility[1].swing_K': 0.2; expected 0.5"),
    (lambda p: p[0].update(largest_swing_K=-1), "field 'plausibility[0].largest_swing_K': -1; expected the largest"),
    (lambda p: p[1].pop("swing_K"), "field 'plausibility[1]': expected an object with gate_K, intercept, largest_K, "
                                    "largest_swing_K, sensor, slopes, swing_K (every relation with the swing gate"),
])
def test_a_bad_plausibility_section_is_named_by_its_field(tmp_path, edit, expected):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    edit(doc["plausibility"])
    (tmp_path / "m.json").write_text(json.dumps(doc))
    with pytest.raises(UserError) as caught:
        load_model(tmp_path / "m.json")
    assert expected in str(caught.value)


def test_the_ambient_is_no_slope_and_has_the_swing_test_alone():
    lumped = load_model(GOLDEN / "lumped.json")  # T_env is its ambient: it drives the machine through hours of lag
    relations = {r.sensor: r for r in lumped.plausibility.relations}
    assert [name for name, _ in relations["T_motor"].slopes] == ["T_bearing"]
    assert relations["T_env"].slopes == () and relations["T_env"].gate_K is None and relations["T_env"].swing_K


@pytest.mark.parametrize("edit, expected", [
    (lambda p: p[2].update(slopes={"T_motor": {"f64": 1.0, "f32": "0x3F800000"}}),
     "field 'plausibility[2].slopes': expected none ({}): no other temperature the block checks follows T_env"),
    (lambda p: p[2].update(gate_K={"f64": 2.0, "f32": "0x40000000"}),
     "field 'plausibility[2].gate_K': {'f64': 2.0, 'f32': '0x40000000'}; expected null: a relation without slopes"),
    (lambda p: p[0]["slopes"].update(T_env={"f64": 1.0, "f32": "0x3F800000"}),
     "field 'plausibility[0].slopes': expected one slope for each of T_bearing, in that order"),
])
def test_a_bad_ambient_relation_is_named_by_its_field(tmp_path, edit, expected):
    doc = json.loads((GOLDEN / "lumped.json").read_text())
    edit(doc["plausibility"])
    (tmp_path / "m.json").write_text(json.dumps(doc))
    with pytest.raises(UserError) as caught:
        load_model(tmp_path / "m.json")
    assert expected in str(caught.value)


def test_fit_writes_the_relations_of_every_temperature(tmp_path):
    kalman = load_model(GOLDEN / "kalman.json")  # its filter judges T_motor and T_bearing: read as last in range
    assert kalman.plausibility.sensors() == ["T_motor", "T_bearing", "T_env"]
    lumped = load_model(GOLDEN / "lumped.json")
    assert lumped.plausibility.sensors() == ["T_motor", "T_bearing", "T_env"]
    assert replace(lumped, plausibility=None).fingerprint() != lumped.fingerprint()
