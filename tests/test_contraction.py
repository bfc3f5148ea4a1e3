"""Issue 64 item 4: what a target that contracts multiply-adds shows. The fused rounding is libm's fmaf bit
for bit; verify states the deviation of the fused replay, finite and far below the model's held-out error."""
from __future__ import annotations

import ctypes
import ctypes.util
import json

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from tests.cli_runner import thermoplc
from tests.golden_models import FUSED, FUSED_EVERY, GOLDEN, KINDS, golden_block, golden_twin_csv
from thermoplc.models.modelfile import load_model
from thermoplc.recordings.table import read_table
from thermoplc.verifier.engines.contraction import ContractingMachine, fused
from thermoplc.verifier.reading.parser import parse_text
from thermoplc.verifier.replays.replay import verify_against_model

_LIBM = ctypes.util.find_library("m")
binary32 = st.floats(width=32, allow_nan=False, allow_infinity=False)


def _fmaf():
    fmaf = ctypes.CDLL(_LIBM).fmaf
    fmaf.restype, fmaf.argtypes = ctypes.c_float, [ctypes.c_float] * 3
    return fmaf


def _bits(x: float) -> int:
    return int(np.float32(x).view(np.uint32))


@pytest.mark.skipif(_LIBM is None, reason="no C maths library to compare with on this machine")
@settings(max_examples=3000, deadline=None)
@given(binary32, binary32, binary32)
@example(1 + 2 ** -12, 1 + 2 ** -12, 2.0 ** -60)  # the binary64 sum is a binary32 tie: rounding twice is wrong
@example(1 + 2 ** -12, 1 + 2 ** -12, -(2.0 ** -60))
@example(1e-20, 1e-20, 0.0)  # the product below binary32's normal range
def test_a_fused_multiply_add_rounds_as_fmaf(a, b, c):
    want = _fmaf()(a, b, c)
    with np.errstate(over="ignore"):
        got = float(np.float32(fused(a, b, c)))
    if np.isfinite(want):
        assert _bits(got) == _bits(want), (a, b, c, got, want)


def _run(body: str, **inputs) -> float:
    machine = ContractingMachine(parse_text(
        f"FUNCTION_BLOCK B VAR_INPUT a, b, c, d : REAL; END_VAR VAR_OUTPUT y : REAL; END_VAR {body} END_FUNCTION_BLOCK",
        "b.st"), "b.st")
    machine.call({name: float(np.float32(v)) for name, v in inputs.items()})
    return machine.values[machine.slots["Y"]]


def test_every_form_of_a_multiply_add_is_fused_and_nothing_else():
    a, b, c = (float(np.float32(v)) for v in (1 + 2 ** -12, 1 + 2 ** -12, 2.0 ** -30))
    assert float(np.float32(float(np.float32(a * b)) + c)) != float(np.float32(fused(a, b, c)))  # fusing shows
    assert _run("y := a * b + c;", a=a, b=b, c=c) == float(np.float32(fused(a, b, c)))
    assert _run("y := c + a * b;", a=a, b=b, c=c) == float(np.float32(fused(a, b, c)))
    assert _run("y := a * b - c;", a=a, b=b, c=-c) == float(np.float32(fused(a, b, c)))
    assert _run("y := c - a * b;", a=-a, b=b, c=c) == float(np.float32(fused(a, b, c)))
    product = float(np.float32(a * b))
    assert _run("y := a * b;", a=a, b=b) == product  # a product alone is rounded as ever
    assert _run("y := (a + b) * c;", a=a, b=b, c=c) == float(np.float32(float(np.float32(a + b)) * c))


@pytest.fixture(scope="module")
def twin(tmp_path_factory):
    return read_table(golden_twin_csv(tmp_path_factory.mktemp("contraction")))


@pytest.mark.parametrize("kind", [k if k in ("mlr", "kalman_fused") else pytest.param(k, marks=pytest.mark.slow)
                                  for k in (*KINDS, *FUSED)])
def test_the_stated_deviation_is_finite_and_a_tenth_of_the_held_out_error_at_most(kind, twin):
    model_path = GOLDEN / f"{kind}.json"
    model = load_model(model_path)
    report = verify_against_model(str(golden_block(kind, "tia")), model, str(model_path), twin,
                                  probe_every=FUSED_EVERY if kind in FUSED else None)
    assert report.ok and report.contraction is not None and not report.contraction.failure
    assert report.contraction.calls == twin.rows
    deviation = report.contraction.deviation[model.target.name]
    assert np.isfinite(deviation) and deviation <= model.metrics["held_out"]["rmse_um"] / 10
    assert "contraction: a target that fuses each a*b+c" in report.text()


def test_verify_prints_and_writes_the_contraction(tmp_path):
    data = golden_twin_csv(tmp_path)
    result = thermoplc("verify", golden_block("kalman", "iec"), "--model", GOLDEN / "kalman.json", "--data", data,
                       "--json", "report.json", cwd=tmp_path)
    line = next(line for line in result.stdout.splitlines() if "contraction:" in line)
    assert "differs by at most E_z_um" in line and "over 4,321 calls" in line
    document = json.loads((tmp_path / "report.json").read_text())
    assert document["contraction"]["calls"] == 4321
    assert document["contraction"]["max_deviation"]["E_z_um"]["type"] == "REAL"


def test_a_long_recording_is_judged_on_its_first_calls_and_says_so(twin, monkeypatch):
    from thermoplc.verifier.engines import contraction
    monkeypatch.setattr(contraction, "MAX_CALLS", 500)
    model_path = GOLDEN / "kalman.json"
    report = verify_against_model(str(golden_block("kalman", "step7")), load_model(model_path), str(model_path), twin)
    assert report.contraction.calls == 500 and report.contraction.rows == twin.rows
    assert f"over 500 calls (the first of {twin.rows:,})" in report.text()
