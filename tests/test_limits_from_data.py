"""Issue 61, item 6: the clamp, rate limit and speed guard come from the recording (models/envelope.py)."""
from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, strategies as st

from thermoplc.base.errors import UserError
from thermoplc.fitting.envelope_fit import measure_envelope
from thermoplc.models.envelope import Envelope, data_limits, round_up
from thermoplc.models.modelfile import load_model
from thermoplc.models.model import Signal
from thermoplc.models.reference import block_outputs, model_inputs
from thermoplc.models.safety import CLAMPED, Limits
from thermoplc.recordings.table import Table, read_table
from tests.cli_runner import thermoplc
from tests.golden_models import GOLDEN, KINDS, batch_csvs, golden_twin_csv


@given(st.floats(min_value=1e-6, max_value=1e9, allow_nan=False))
def test_a_limit_is_rounded_up_to_two_significant_digits_and_never_below(value):
    rounded = round_up(value)
    assert rounded >= value * (1 - 1e-9)
    assert rounded <= value * 1.1 + 1e-12  # one step of the second digit at most
    digits = f"{rounded:.6e}".split("e")[0].replace(".", "").rstrip("0")
    assert len(digits) <= 2


def test_rounding_keeps_round_numbers_and_takes_the_next_step_otherwise():
    assert [round_up(v) for v in (106.5, 1.13, 7500.0, 0.1 * 3, 99.9, 0.0012345)] == [110.0, 1.2, 7500.0, 0.3, 100.0,
                                                                                        0.0013]


def test_the_limits_are_one_and_a_half_the_recorded_extremes_the_rate_the_machines_own():
    envelope = Envelope(1000, (68.7, 63.5), (0.753, 3.87), 5000.0)
    chosen = data_limits(envelope, 15.0)
    assert (chosen["max_output"].value, chosen["max_step"].value, chosen["max_speed_rpm"].value) == (110.0, 1.2, 7500.0)
    assert "68.7 (measured)" in chosen["max_output"].why and "0.753 (measured)" in chosen["max_step"].why
    timid = data_limits(Envelope(10, (2.0, 30.0), (0.0, 0.4), None), 15.0)
    assert timid["max_output"].value == 45.0 and "the model's" in timid["max_output"].why
    assert timid["max_step"].value == 0.6 and "none measured" in timid["max_step"].why
    assert "max_speed_rpm" not in timid
    assert list(data_limits(Envelope(1, (0.0, 0.0), (0.0, 0.0), 0.0), 15.0)) == ["stuck_calls"]


def test_a_limit_given_wins_and_a_model_without_an_envelope_keeps_the_fixed_defaults():
    model = load_model(GOLDEN / "kalman.json")
    given = Limits.for_model(model, max_output=150.0, max_step=None)
    assert given.max_output == 150.0 and given.origin("max_output") == ""
    assert given.max_step == round_up(1.5 * model.envelope.step_um[0]) and given.origin("max_step")
    assert given.max_speed_rpm == round_up(1.5 * model.envelope.speed_rpm)
    bare = Limits.for_model(replace(model, envelope=None))
    assert (bare.max_output, bare.max_step, bare.max_speed_rpm) == (300.0, 2.0, 100000.0)
    assert [name for name, _ in bare.origins] == ["stuck_calls"]  # an hour of calls, said so


def test_the_envelope_is_measured_per_call_over_every_row():
    drift = [0.0, 1.0, math.nan, math.nan, 4.0, -6.0]  # 3 um over 3 calls: 1 per call; then 10 in one
    columns = {"time_s": np.arange(6) * 10.0, "T_a": 20 + 0.1 * np.arange(6),
               "n_rpm": np.array([0, 1e3, -3e3, 0, 0, 0]),
               "E_um": np.array(drift)}
    model = load_model(GOLDEN / "kalman.json")
    model = replace(model, target=Signal("E_um", "E_um", "target", "um"),
                    inputs=tuple(replace(s, column="n_rpm" if s.role == "speed" else "T_a") for s in model.inputs))
    envelope = measure_envelope(model, [Table("r.csv", columns, "r", np.arange(2, 8))])
    assert envelope.rows == 6
    assert envelope.drift_um[0] == 6.0 and envelope.step_um[0] == 10.0
    assert envelope.speed_rpm == 3000.0


@pytest.fixture(scope="module")
def golden_runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("runs")
    return {p.name: read_table(p) for p in (golden_twin_csv(folder), *batch_csvs(folder))}


@pytest.mark.parametrize("kind", KINDS)
def test_a_golden_blocks_limits_never_clamp_the_recording_they_came_from(kind, golden_runs):
    model = load_model(GOLDEN / f"{kind}.json")
    limits = Limits.for_model(model)
    assert limits.max_output < 300.0 and limits.origin("max_output")
    for run in model.training.get("batches", [model.training]):
        table = golden_runs[run["file"]]
        out = block_outputs(model, model_inputs(model, table), "f32", limits)
        assert not np.any(out[CLAMPED]), f"{kind}: clamped at +-{limits.max_output} on {run['file']}"


def test_generate_states_each_limit_it_took_from_the_recording_and_the_option_that_sets_it(tmp_path):
    result = thermoplc("generate", GOLDEN / "kalman.json", "-o", tmp_path / "k.scl", cwd=tmp_path)
    model = load_model(GOLDEN / "kalman.json")
    chosen = data_limits(model.envelope, model.sample_period_s)
    clamp, rate, speed = (chosen[f].value for f in ("max_output", "max_step", "max_speed_rpm"))
    assert f"  --max-offset-um {clamp:g}: 1.5 x the largest |drift| recorded" in result.stdout
    assert f"  --max-step-um {rate:g}: 1.5 x the drift's fastest change per call recorded" in result.stdout
    assert f"  --max-speed-rpm {speed:g}: 1.5 x the largest |speed| recorded" in result.stdout
    text = (tmp_path / "k.scl").read_text()
    assert f"c_OutMax : Real := {clamp:.1f};   // output clamp: 1.5 x the largest |drift| recorded" in text
    assert f"c_SpeedMax : Real := {speed:.1f};   // highest plausible speed, rpm: 1.5 x" in text
    assert "(--max-speed-rpm)" in text
    thermoplc("generate", GOLDEN / "kalman.json", "-o", tmp_path / "g.scl", "--max-offset-um", "150",
              "--max-speed-rpm", "8000", cwd=tmp_path)
    given = (tmp_path / "g.scl").read_text()
    assert "c_OutMax : Real := 150.0;   // output clamp (--max-offset-um)" in given
    assert "c_SpeedMax : Real := 8000.0;   // highest plausible speed, rpm (--max-speed-rpm)" in given
    verified = thermoplc("verify", tmp_path / "k.scl", "--model", GOLDEN / "kalman.json", "--data",
                         golden_twin_csv(tmp_path), cwd=tmp_path, check=None)
    assert verified.returncode == 0, verified.stdout + verified.stderr
    assert f"outputs within +-{clamp:g}, at most {rate:g} per call" in verified.stdout


@pytest.mark.parametrize("field, value, expected", [
    ("rows", 0, "field 'envelope.rows': 0; expected the number of rows measured"),
    ("drift_um", {"measured": -1.0, "model": 2.0}, "field 'envelope.drift_um.measured': -1.0; expected a number"),
    ("step_um", {"measured": 1.0}, "field 'envelope.step_um': expected an object with measured and model"),
    ("speed_rpm", "fast", "field 'envelope.speed_rpm': 'fast'"),
    ("extra", 1, "field 'envelope.extra': not part of the envelope"),
])
def test_a_bad_envelope_is_named_by_its_field(tmp_path, field, value, expected):
    doc = json.loads((GOLDEN / "kalman.json").read_text())
    doc["envelope"][field] = value
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(UserError) as caught:
        load_model(path)
    assert expected in str(caught.value)


def test_an_old_model_file_without_an_envelope_gets_the_fixed_limits_and_says_nothing_of_data(tmp_path):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    del doc["envelope"]
    (tmp_path / "m.json").write_text(json.dumps(doc))
    result = thermoplc("generate", "m.json", "-o", "m.scl", cwd=tmp_path)
    assert "outputs within +-300, at most 2 per call" in result.stdout and "recorded" not in result.stdout


@pytest.mark.parametrize("tiny", [5e-324, 1e-300, 1e-9])
def test_an_envelope_of_no_drift_leaves_the_fixed_limits_and_never_a_zero_clamp(tmp_path, tiny):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["envelope"]["drift_um"] = {"measured": tiny, "model": tiny}
    doc["envelope"]["step_um"] = {"measured": tiny, "model": 0.0}
    (tmp_path / "m.json").write_text(json.dumps(doc))
    result = thermoplc("generate", "m.json", "-o", "m.scl", cwd=tmp_path)
    assert "outputs within +-300, at most 2 per call" in result.stdout and "Traceback" not in result.stderr


def test_a_model_without_a_speed_input_has_no_speed_guard_to_take_or_give(tmp_path):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["envelope"]["speed_rpm"] = 1e6  # hand-edited: the model reads no speed
    (tmp_path / "m.json").write_text(json.dumps(doc))
    result = thermoplc("generate", "m.json", "-o", "m.scl", cwd=tmp_path)
    assert "--max-speed-rpm" not in result.stdout and "c_SpeedMax" not in (tmp_path / "m.scl").read_text()
    refused = thermoplc("generate", "m.json", "-o", "n.scl", "--max-speed-rpm", "5", cwd=tmp_path, check=2)
    assert refused.stderr == ("thermoplc: error: --max-speed-rpm 5: the model reads no speed input, so the block has "
                              "no speed guard; leave the option out\n")
    assert not (tmp_path / "n.scl").exists()


def test_a_limit_that_is_zero_as_a_real_is_refused():
    with pytest.raises(UserError, match="max_output must be a positive finite number"):
        Limits(max_output=1e-300)

