"""The known start (issue 61 item 1, models/start.py): a block starts at the drift its runs started at."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from thermoplc.base.binary32 import FADE_FLOOR
from thermoplc.base.errors import UserError
from thermoplc.demo import AMBIENT, SPEED, TARGET, TEMPS, recording
from thermoplc.fitting.acceptance import problem
from thermoplc.fitting.fit import FitRequest, evaluate, fit
from thermoplc.models.modelfile import load_model
from thermoplc.models.reference import block_outputs, model_inputs
from thermoplc.models.safety import RESET, Limits
from thermoplc.models import start as module
from thermoplc.models.start import Start, apply
from thermoplc.recordings.table import read_table
from tests.cli_runner import thermoplc
from tests.golden_models import GOLDEN


@pytest.fixture(scope="module")
def fl_table():
    return read_table(recording())


@pytest.fixture(scope="module")
def fl_models(fl_table):
    fitted = {}
    for kind in ("mlr", "kalman"):
        extra = (SPEED, AMBIENT) if kind == "kalman" else (None, None)
        fitted[kind] = fit([fl_table], FitRequest(kind, TARGET, TEMPS, *extra, train_until=24 * 3600.0))
    return fitted


@pytest.mark.parametrize("kind", ["mlr", "kalman"])
def test_on_fl_thermal_the_block_starts_at_the_measured_drift_and_the_held_out_error_stays(fl_table, fl_models, kind):
    model = fl_models[kind]
    measured = fl_table.columns[TARGET]
    out = block_outputs(model, model_inputs(model, fl_table), "f32", Limits())[model.target.name]
    without = block_outputs(replace(model, start=None), model_inputs(model, fl_table), "f32", Limits())[TARGET]
    first_ten_minutes = fl_table.columns["time_s"] - fl_table.columns["time_s"][0] <= 600
    assert abs(float(out[0]) - measured[0]) < 1.0
    assert abs(float(without[0]) - measured[0]) >= 2.0  # the model alone starts off (the limiter's first step)
    assert np.max(np.abs(out[first_ten_minutes] - measured[first_ten_minutes])) \
        < np.max(np.abs(without[first_ten_minutes] - measured[first_ten_minutes]))
    split = model.training["rows"]
    with_start = evaluate(model, [fl_table], [split])["held_out"]["rmse_um"]
    no_start = evaluate(replace(model, start=None), [fl_table], [split])["held_out"]["rmse_um"]
    assert with_start <= 1.05 * no_start
    assert model.metrics["start"]["max_abs_um"] < 1e-9


def test_a_reset_latches_the_start_again(fl_table, fl_models):
    model = fl_models["mlr"]
    inputs = model_inputs(model, fl_table)
    rows = 2000
    reset = np.zeros(rows, bool)
    reset[1000] = True
    cut = {k: v[:rows] for k, v in inputs.items()}
    out = block_outputs(model, cut, "f32", Limits(max_step=1e6), {RESET: reset})[model.target.name]
    fresh = block_outputs(model, {k: v[1000:rows] for k, v in inputs.items()}, "f32", Limits(max_step=1e6))
    assert out[1000:].view(np.uint32).tolist() == fresh[model.target.name].view(np.uint32).tolist()
    assert out[1000] == np.float32(model.start.drift_um[1]) or abs(float(out[1000]) - model.start.drift_um[0]) < 1e-5


def test_the_compiled_and_the_python_loop_agree_bit_for_bit_and_nan_latches_nothing():
    start = Start.of(0.25, 0.99)
    values = np.array([np.nan, np.inf, 3.0, 3.5, -1e30, 2.0], np.float32)
    compiled = apply(start, values, "f32")
    state, python = np.zeros(2, np.float32), np.empty(len(values), np.float32)
    f = np.float32
    getattr(module._apply, "py_func", module._apply)(values, f(0.25), f(0.99), f(3.402823e38), f(FADE_FLOOR), f(0),
                                                     state, python)
    assert compiled.view(np.uint32).tolist() == python.view(np.uint32).tolist()
    assert np.isnan(compiled[0]) and np.isinf(compiled[1])  # nothing latched: the limiter holds the output
    assert compiled[2] == np.float32(np.float32(3.0) + (np.float32(0.25) - np.float32(3.0)))
    chunked = np.concatenate([apply(start, values[:3], "f32", state := np.zeros(2, np.float32)),
                              apply(start, values[3:], "f32", state)])
    assert chunked.view(np.uint32).tolist() == compiled.view(np.uint32).tolist()


@pytest.mark.parametrize("field, value, expected", [
    ("decay", {"f64": 1.0, "f32": "0x3F800000"}, "field 'start.decay': 1.0; expected a factor per call from 1e-06 to below 1, or 0"),
    ("decay", {"f64": -0.5, "f32": "0xBF000000"}, "field 'start.decay'"),
    ("drift_um", {"f64": 0.5}, "field 'start.drift_um': expected"),
    ("extra", {"f64": 0.5, "f32": "0x3F000000"}, "field 'start.extra': not a constant of the start"),
])
def test_a_bad_start_section_is_named_by_its_field(tmp_path, field, value, expected):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["start"][field] = value
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(UserError) as caught:
        load_model(path)
    assert expected in str(caught.value)


def test_a_start_error_beyond_the_held_out_rmse_is_refused_by_generate(tmp_path):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["metrics"]["start"] = {"runs": 1, "max_abs_um": 12.0}
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc))
    assert "at a run's start (first call) it is 12 um off" in problem(load_model(path))
    result = thermoplc("generate", path, "-o", tmp_path / "m.scl", cwd=tmp_path, check=2)
    assert "at a run's start (first call) it is 12 um off" in result.stderr
    assert not (tmp_path / "m.scl").exists()


def test_fit_prints_the_start_error_beside_the_held_out_rmse(tmp_path):
    result = thermoplc("fit", "--data", recording(), "--model", "mlr", "--target", TARGET, "--temps", ",".join(TEMPS),
                       "--train-until", 86400, "-o", "m.json", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "  start (first call)                             0.000   worst of 1 run start" in result.stdout
    header = thermoplc("generate", "--stats", "m.json", "-o", "m.scl", cwd=tmp_path)
    assert header.returncode == 0, header.stderr
    text = (tmp_path / "m.scl").read_text()
    assert "c_StartDrift : Real := 0.106198;" in text and "#StartOffset := #StartOffset * #c_StartDecay;" in text
    assert "c_StartFloor : Real := 1.0E-6;" in text


def test_a_model_file_without_a_known_start_is_generated_and_says_so(tmp_path):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    del doc["start"]
    (tmp_path / "m.json").write_text(json.dumps(doc))
    result = thermoplc("generate", "m.json", "-o", "m.scl", cwd=tmp_path)
    assert "  no known start in the model file (written before thermoplc fitted one)" in result.stdout
    assert "StartOffset" not in (tmp_path / "m.scl").read_text()
