"""The compiled reference (models/kernels.py and each kind's loop) equals the numpy/Python reference bit for bit:
every golden model, clean and with every injected fault, NaN/Inf and out-of-range inputs, both
precisions; and the compiled loops carry no FMA or fast-math flag."""
import numpy as np
import pytest

from tests.golden_models import GOLDEN, KINDS, golden_twin_csv
from thermoplc.base import compiled
from thermoplc.models import kernels, lumped_kernel
from thermoplc.models.kinds import grey, kalman
from thermoplc.models.modelfile import load_model
from thermoplc.models.reference import block_outputs, model_inputs
from thermoplc.models.safety import ENABLE, ENABLED, RESET, Limits, guards
from thermoplc.recordings.table import read_table
from thermoplc.verifier.replays.faults import FAULT_KINDS, inject

pytestmark = pytest.mark.skipif(compiled.numba is None, reason="numba not installed")


@pytest.fixture(scope="module")
def golden_table(tmp_path_factory):
    return read_table(golden_twin_csv(tmp_path_factory.mktemp("fastref")))


def _both(model, inputs, precision, limits, control=None):
    with compiled.reference("slow"):
        slow = block_outputs(model, inputs, precision, limits, control)
    with compiled.reference("fast"):
        fast = block_outputs(model, inputs, precision, limits, control)
    return slow, fast


def _assert_same_bits(slow: dict, fast: dict, label) -> None:
    assert list(slow) == list(fast), label
    for name, want in slow.items():
        got = fast[name]
        assert got.dtype == want.dtype, (label, name)
        if want.dtype.kind == "f":
            bits = np.uint32 if want.dtype == np.float32 else np.uint64
            differ = np.flatnonzero(got.view(bits) != want.view(bits))
            assert len(differ) == 0, (label, name, differ[:5])
        else:
            assert np.array_equal(got, want), (label, name)


@pytest.mark.parametrize("precision", ["f32", "f64"])
@pytest.mark.parametrize("kind", KINDS)
def test_fast_reference_equals_slow_on_every_golden_model(kind, precision, golden_table):
    model = load_model(GOLDEN / f"{kind}.json")
    inputs = model_inputs(model, golden_table)
    slow, fast = _both(model, inputs, precision, Limits())
    _assert_same_bits(slow, fast, kind)


@pytest.mark.parametrize("kind", KINDS)
def test_fast_reference_equals_slow_with_enable_and_reset(kind, golden_table):
    """Segments after each Reset start the guards afresh and the limiter from the held outputs."""
    model = load_model(GOLDEN / f"{kind}.json")
    inputs = {k: v[:2000] for k, v in model_inputs(model, golden_table).items()}
    enable = np.ones(2000, bool)
    enable[300:420] = False
    reset = np.zeros(2000, bool)
    reset[[0, 350, 420, 421, 900]] = True
    reset[1500:1530] = True
    limits = Limits(max_step=0.05, max_output=3.0)  # held outputs ramp: the limiter's carried state matters
    for precision in ("f32", "f64"):
        slow, fast = _both(model, inputs, precision, limits, {ENABLE: enable, RESET: reset})
        _assert_same_bits(slow, fast, (kind, precision))
        assert not slow[ENABLED][300:420].any() and slow[ENABLED][:300].all()


@pytest.mark.parametrize("kind", KINDS)
def test_fast_reference_equals_slow_on_fault_data(kind, golden_table):
    model = load_model(GOLDEN / f"{kind}.json")
    clean = {k: v[:1500] for k, v in model_inputs(model, golden_table).items()}
    times = golden_table.columns[model.time_column][:1500]
    limits = Limits(max_step=0.05, max_output=3.0, settle_calls=5)  # the limiter and the clamp act
    for g in guards(model):
        for fault in FAULT_KINDS:
            inputs = dict(clean)
            inputs[g.name], _ = inject(clean[g.name], np.asarray(times), fault, 200)
            slow, fast = _both(model, inputs, "f32", limits)
            _assert_same_bits(slow, fast, (kind, g.name, fault.name))


@pytest.mark.parametrize("kind", KINDS)
def test_fast_reference_equals_slow_on_hostile_inputs(kind, golden_table):
    """NaN, +-Inf, out of range, huge and subnormal values on every input, at random calls, and a
    start with no valid call for a while."""
    model = load_model(GOLDEN / f"{kind}.json")
    rng = np.random.default_rng(17)
    clean = {k: v[:800].copy() for k, v in model_inputs(model, golden_table).items()}
    specials = np.array([np.nan, np.inf, -np.inf, 3276.7, -3276.8, 3.0e38, -3.0e38, 1e-40, 0.0, -0.0, 151.0],
                        np.float32)
    for trial in range(4):
        inputs = {}
        for name, v in clean.items():
            v = v.copy()
            hit = rng.random(len(v)) < 0.05
            v[hit] = rng.choice(specials, int(hit.sum()))
            if trial == 0:
                v[:40] = np.nan  # the model starts late
            inputs[name] = v
        for precision in ("f32", "f64"):
            slow, fast = _both(model, inputs, precision, Limits(settle_calls=3))
            _assert_same_bits(slow, fast, (kind, trial, precision))


def _call_every_loop(f) -> None:
    kalman.kalman_loop(np.ones(3, f), np.ones(3, f), [np.ones(3, f)], [np.ones(3, bool)],
                       kalman.Sensors(*np.ones((10, 1), f)), np.ones(1, f), f(0), f)
    kernels.hold(np.ones(3, f), np.ones(3, bool), np.zeros(3, bool), False, 0, 3, 1.0, f)
    kernels.repeats(np.ones(3, f), np.ones(3, bool), 2, f)
    grey.gm0n_loop([np.ones(3, f)], 1.0, [1.0], f)
    grey.gm1n_loop([np.ones(3, f)], 1.0, 1.0, 1.0, [1.0], f)
    kernels.limit(np.ones(3, f), 0, np.zeros(1, f), np.zeros(3, f), np.zeros(3, bool), np.zeros(3, bool),
                  np.zeros(3, bool), Limits().values(), f)
    lumped_kernel.lumped_loop([np.ones(3, f)], np.ones(3, f), np.ones(3, f), None, (True,) * 6 + (False,) + (True,) * 4,
                              {}, [(1.0, 1.0, 1.0)], 0, f)


def test_compiled_loops_contract_nothing():
    """No fused multiply-add and no fast-math flag in the LLVM IR of any compiled loop."""
    with compiled.reference("fast"):  # three calls would run as Python in 'auto'
        _call_every_loop(np.float32)
    for fn in (kalman._kalman, kernels._hold, kernels._repeats, kernels._limit, grey._gm0n, grey._gm1n,
               lumped_kernel._lumped):
        fresh = compiled.numba.njit(**{**compiled.JIT_OPTIONS, "cache": False})(fn.py_func)  # cached code has no IR
        for signature in fn.signatures:
            fresh.compile(signature)
        assert fresh.signatures
        for ir in fresh.inspect_llvm().values():
            assert "fadd" in ir or "fmul" in ir or "fcmp" in ir
            assert "fma" not in ir and "fmuladd" not in ir, fn
            for flag in (" fast ", " contract ", " reassoc ", " afn ", " nnan ", " ninf "):
                assert flag not in ir, (fn, flag)


def test_kalman_kernel_rounds_each_operation_where_fma_would_not():
    """tp = A*tf + B*te + C*n + D over many calls with random inputs: equal to numpy float32 scalars
    rounding after every operation, and different from what fused multiply-adds would give."""
    f = np.float32
    rng = np.random.default_rng(3)
    rows = 5000
    te, n = rng.uniform(-30, 30, rows).astype(f), rng.uniform(-3, 3, rows).astype(f)
    temp = rng.uniform(15, 25, rows).astype(f)
    sc = np.array([[0.999, 0.998, 0.0013, 0.0007, 0.011, 1e-3, 0.5, 0.5, -1.0, 0.1]], f)  # Jmp < 0: model only
    with compiled.reference("fast"):
        error, _ = kalman.kalman_loop(te, n, [temp], [np.ones(rows, bool)], kalman.Sensors(*sc.T), np.ones(1, f), f(0),
                                      f)
    a, b, c, d = (f(x) for x in sc[0, [0, 2, 3, 4]])
    tf = t0 = temp[0]
    separate, fused = [], []
    tf_fused = tf
    fma = lambda x, y, z: f(np.float64(x) * np.float64(y) + np.float64(z))  # x*y exact in binary64
    for j in range(rows):
        tf = a * tf + b * te[j] + c * n[j] + d
        separate.append(f(1) * (tf - t0))
        tf_fused = fma(c, n[j], fma(b, te[j], a * tf_fused)) + d
        fused.append(f(1) * (tf_fused - t0))
    assert np.array_equal(error.view(np.uint32), np.array(separate, f).view(np.uint32))
    assert not np.array_equal(error, np.array(fused, f))  # the data tells fused from separate rounding


def _streamed(model, inputs, precision, limits, sizes):
    from thermoplc.models.streaming import StreamingReference
    stream = StreamingReference(model, limits, precision)
    rows = len(next(iter(inputs.values())))
    parts, at, k = [], 0, 0
    while at < rows:
        n = sizes[k % len(sizes)]
        parts.append(stream.step({name: v[at:at + n] for name, v in inputs.items()}))
        at, k = at + n, k + 1
    return {name: np.concatenate([p[name] for p in parts]) for name in parts[0]}


@pytest.mark.parametrize("kind", ["kalman", "mlr", "gm0n", "gm1n", "piecewise", "bpnn", "bayes", "dlag", "lumped"])
def test_streamed_reference_equals_the_whole_recording_at_any_chunk_boundary(kind, golden_table):
    from thermoplc.models.streaming import streamable
    model = load_model(GOLDEN / f"{kind}.json")
    if not streamable(model):
        pytest.skip(f"the golden {kind} model is not streamed")
    clean = {k: v[:1200] for k, v in model_inputs(model, golden_table).items()}
    times = np.asarray(golden_table.columns[model.time_column][:1200])
    rng = np.random.default_rng(5)
    cases = [("clean", clean, Limits())]
    late = {k: v.copy() for k, v in clean.items()}
    for v in late.values():
        v[:37] = np.nan  # the model starts inside the second chunk
    cases.append(("late start", late, Limits()))
    never = {k: np.full_like(v, np.nan) for k, v in clean.items()}
    cases.append(("never starts", never, Limits()))
    for g in guards(model):
        for fault in FAULT_KINDS:
            inputs = dict(clean)
            inputs[g.name], _ = inject(clean[g.name], times, fault, 100)
            cases.append((f"{g.name} {fault.name}", inputs, Limits(max_step=0.05, max_output=3.0, settle_calls=5)))
    hostile = {k: v.copy() for k, v in clean.items()}
    for v in hostile.values():
        hit = rng.random(len(v)) < 0.05
        v[hit] = rng.choice(np.array([np.nan, np.inf, -np.inf, 3276.7, 1e-40, 3e38], np.float32), int(hit.sum()))
    cases.append(("hostile", hostile, Limits(settle_calls=3)))
    for label, inputs, limits in cases:
        for precision in ("f32", "f64"):
            with compiled.reference("slow"):
                whole = block_outputs(model, inputs, precision, limits)
            streamed = _streamed(model, inputs, precision, limits, [1, 36, 7, 500, 3])
            _assert_same_bits(whole, streamed, (kind, label, precision))
