"""Issue 61, item 4: a temperature that repeats its reading too long is stuck and sets its fault bit
(models/safety.py, models/envelope.py says how long is too long)."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from thermoplc.base import compiled
from thermoplc.base.errors import UserError
from thermoplc.fitting.envelope_fit import longest_repeat, measure_envelope
from thermoplc.models.envelope import STUCK_MAX, Envelope, data_limits
from thermoplc.models.kind import fault_key
from thermoplc.models.modelfile import load_model
from thermoplc.models.reference import block_outputs, model_inputs
from thermoplc.models.safety import Limits
from thermoplc.models.streaming import StreamingReference
from thermoplc.recordings.table import read_table, write_table
from tests.cli_runner import thermoplc
from tests.golden_models import GOLDEN, golden_twin_csv

FROZEN = slice(10, 21)  # rows 10..20 read the value of row 10


def _inputs(rows: int = 40) -> dict:
    motor = (20 + 0.01 * np.arange(rows)).astype(np.float32)
    motor[FROZEN] = motor[FROZEN.start]
    return {"T_motor": motor, "T_bearing": (25 + 0.02 * np.arange(rows)).astype(np.float32)}


@pytest.mark.parametrize("reference", ["slow", "fast"])
def test_the_fifth_repeat_sets_the_fault_bit_and_a_moving_reading_settles_it(reference):
    model = load_model(GOLDEN / "mlr.json")
    limits = Limits(stuck_calls=5, settle_calls=3)
    with compiled.reference(reference):
        out = block_outputs(model, _inputs(), "f32", limits)
    fault = np.asarray(out[fault_key("T_motor")], bool)
    # row 11 is the first repeat, row 15 the fifth; row 21 moves again and the third steady call (23) releases it
    assert np.flatnonzero(fault).tolist() == list(range(15, 23))
    assert not np.asarray(out[fault_key("T_bearing")], bool).any()
    unchecked = block_outputs(model, _inputs(), "f32", replace(limits, stuck_calls=None))
    assert not np.asarray(unchecked[fault_key("T_motor")], bool).any()  # a block generated before the check


def test_the_repeat_count_carries_from_one_chunk_to_the_next():
    model = load_model(GOLDEN / "mlr.json")
    limits = Limits(stuck_calls=5, settle_calls=3)
    whole = block_outputs(model, _inputs(), "f32", limits)
    stream = StreamingReference(model, limits, "f32")
    pieces = [stream.step({k: v[a:a + 7] for k, v in _inputs().items()}) for a in range(0, 40, 7)]
    for name, values in whole.items():
        chunked = np.concatenate([p[name] for p in pieces])
        assert chunked.view(np.uint8).tobytes() == np.asarray(values).view(np.uint8).tobytes(), name


def test_the_longest_repeat_counts_calls_equal_to_the_one_before():
    assert longest_repeat(np.array([1, 2, 2, 2, 3, 3], np.float32)) == 2
    assert longest_repeat(np.array([np.nan, np.nan, 1.0], np.float32)) == 0  # NaN equals nothing
    assert longest_repeat(np.array([5.0], np.float32)) == 0


def test_the_stuck_time_is_one_and_a_half_the_longest_repeat_and_never_under_ten_minutes():
    quantised = data_limits(Envelope(10000, (1.0, 1.0), (0.1, 0.1), None, 600), 15.0)["stuck_calls"]
    assert quantised.value == 900 and "longest run of repeated readings recorded, 600, rounded up" in quantised.why
    floating = data_limits(Envelope(10000, (1.0, 1.0), (0.1, 0.1), None, 1), 15.0)["stuck_calls"]
    assert floating.value == 40 and floating.why == ("10 min of calls: no reading repeated more than 1 time in a row "
                                                     "in the recording")
    assert data_limits(Envelope(10000, (1.0, 1.0), (0.1, 0.1), None, 0), 10.0)["stuck_calls"].value == 60
    capped = data_limits(Envelope(90000, (1.0, 1.0), (0.1, 0.1), None, 40000), 1.0)["stuck_calls"]
    assert capped.value == STUCK_MAX and "the block will flag it there" in capped.why
    old = data_limits(Envelope(10, (1.0, 1.0), (0.1, 0.1), None), 15.0)["stuck_calls"]  # a file before the check
    assert old.value == 240 and old.why.startswith("1 h of calls: the model file records no repeated readings")
    assert data_limits(Envelope(10, (1.0, 1.0), (0.1, 0.1), None, 0), 900.0)["stuck_calls"].value == 2  # 15 min
    assert data_limits(Envelope(90, (1.0, 1.0), (0.1, 0.1), None, 1), 600.0)["stuck_calls"].why == (
        "one more than the longest run of repeated readings recorded, 1")
    assert data_limits(Envelope(90000, (1.0, 1.0), (0.1, 0.1), None, 30000), 1.0)["stuck_calls"].why == (
        "at most 32767 (an INT), above the longest run of repeated readings recorded, 30000")


def test_a_recording_read_in_coarse_steps_never_trips_its_own_block(tmp_path):
    """A card that reads in 0.25 K steps holds a value for many calls while the machine is steady (the golden twin:
    up to 161 calls, 27 min); the time comes from the recording, so its block sets no fault bit replaying it."""
    table = read_table(golden_twin_csv(tmp_path))
    columns = dict(table.columns)
    for name in ("T_motor", "T_bearing", "T_env"):
        columns[name] = np.round(np.asarray(columns[name]) * 4) / 4
    (tmp_path / "steps.csv").write_text(write_table(columns))
    thermoplc("fit", "--data", "steps.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
              "--train-until", "14400", "-o", "m.json", cwd=tmp_path)
    model = load_model(tmp_path / "m.json")
    recorded = read_table(tmp_path / "steps.csv")
    same = max(longest_repeat(v) for v in model_inputs(model, recorded).values())
    assert model.envelope.same_calls == same > 60  # longer than the 10 min floor at 10 s per call
    limits = Limits.for_model(model)
    assert limits.stuck_calls > same and limits.origin("stuck_calls")
    out = block_outputs(model, model_inputs(model, recorded), "f32", limits)
    assert not any(np.asarray(out[fault_key(s.name)], bool).any() for s in model.inputs)
    assert measure_envelope(model, [recorded]).same_calls == same


def test_verify_faults_flags_a_frozen_sensor_and_fails_a_block_that_ignores_it(tmp_path):
    data = golden_twin_csv(tmp_path)
    result = thermoplc("generate", GOLDEN / "mlr.json", "-o", "m.scl", cwd=tmp_path)
    assert "  --stuck-calls 60: 10 min of calls: no reading repeated in the recording" in result.stdout
    assert "stuck after 60 repeats of a reading" in result.stdout
    faults = thermoplc("verify", "m.scl", "--model", GOLDEN / "mlr.json", "--data", data, "--faults", "--json", "-",
                       cwd=tmp_path)
    cases = {(c["sensor"], c["fault"]): c for c in json.loads(faults.stdout)["cases"]}
    assert cases[("T_motor", "stuck")]["flagged"] and cases[("T_bearing", "stuck")]["flagged"]
    text = (tmp_path / "m.scl").read_text()
    planted = text.replace("ELSIF #Same_1 >= #c_StuckCalls THEN", "ELSIF FALSE THEN")
    assert planted != text
    (tmp_path / "p.scl").write_text(planted)
    failed = thermoplc("verify", "p.scl", "--model", GOLDEN / "mlr.json", "--data", data, "--faults", cwd=tmp_path,
                       check=1)
    assert "T_motor         stuck" in failed.stdout


def test_generate_takes_stuck_calls_and_refuses_it_where_no_temperature_is_checked(tmp_path):
    thermoplc("generate", GOLDEN / "mlr.json", "-o", "m.scl", "--stuck-calls", "500", cwd=tmp_path)
    assert ("c_StuckCalls : Int := 500;   // a temperature that repeats its reading this many times in a row is "
            "stuck (--stuck-calls)") in (tmp_path / "m.scl").read_text()
    refused = thermoplc("generate", GOLDEN / "mlr.json", "-o", "n.scl", "--stuck-calls", "1", cwd=tmp_path, check=2)
    assert "--stuck-calls" in refused.stderr and not (tmp_path / "n.scl").exists()
    model = load_model(GOLDEN / "mlr.json")
    unchecked = replace(model, inputs=tuple(replace(s, role="speed") for s in model.inputs))
    with pytest.raises(UserError, match="--stuck-calls 90: the model reads no temperature input"):
        Limits.for_model(unchecked, stuck_calls=90)


@pytest.mark.parametrize("value, expected", [
    (-1, "field 'envelope.same_calls': -1; expected the longest run of repeated readings"),
    (1.5, "field 'envelope.same_calls': 1.5"),
    (True, "field 'envelope.same_calls': True"),
])
def test_a_bad_same_calls_is_named(tmp_path, value, expected):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["envelope"]["same_calls"] = value
    (tmp_path / "m.json").write_text(json.dumps(doc))
    with pytest.raises(UserError) as caught:
        load_model(tmp_path / "m.json")
    assert expected in str(caught.value)
