"""Compiled per-call loops of the float32/float64 references (the fast route, issue 17).

The loops here are the model files' own reference loops (kalman.predict, grey.predict_gm*n,
safety._hold and the limiter of safety.guarded_predict), written once more for numba, in the same
operation order, and compiled by LLVM with fast-math off (no FMA contraction, no reassociation,
IEEE division and NaN semantics). They never see the emitted ST: the proof still compares two
independent computations (the model's loops here, the block's own ST -> C translation in
verifier/native.py).

Rules that keep every value bit-identical to the numpy scalar loops:
- every array and every scalar argument has the precision's dtype (float32 or float64), so
  numba types each operation in that precision: float32 * float32 -> float32, rounded per
  operation as numpy float32 scalars are;
- no Python float literal appears in arithmetic (a literal is float64 and would promote);
- state lives in small arrays the caller passes in, so a recording can be run chunk by chunk
  with the same result as in one piece.

The pure numpy/Python loops stay: they are the oracle in the tests and the path taken when
numba is missing or THERMOPLC_REFERENCE=slow. `enabled()` decides.
"""
from __future__ import annotations

import contextlib
import os

import numpy as np

try:  # numba is a dependency; the slow reference still works without it
    import numba
    _NUMBA_ERROR = ""
except Exception as exc:  # pragma: no cover - exercised only on a broken install
    numba = None
    _NUMBA_ERROR = str(exc)

MODES = ("fast", "slow")
_mode = os.environ.get("THERMOPLC_REFERENCE", "fast")


def enabled() -> bool:
    """True when the compiled loops compute the reference."""
    return numba is not None and _mode == "fast"


def mode() -> str:
    return "fast" if enabled() else "slow"


@contextlib.contextmanager
def reference(which: str):
    """Compute the reference with the compiled loops ('fast') or the numpy/Python loops ('slow')."""
    global _mode
    if which not in MODES:
        raise ValueError(f"reference must be one of {MODES}, got {which!r}")
    before, _mode = _mode, which
    try:
        yield
    finally:
        _mode = before


JIT_OPTIONS = dict(cache=True, fastmath=False, error_model="numpy", nogil=True, boundscheck=False)


def _jit(fn):
    if numba is None:
        return fn
    return numba.njit(**JIT_OPTIONS)(fn)


# ---------------------------------------------------------------------------------------------
# Kalman fusion (models/kalman.py::predict). sc[i] = A, AA, B, C, D, N, R, P0, Jmp, Agr of sensor i.
# state: tf, pf, t0, tm_prev (float, per sensor); fault (bool, per sensor); started[0] (int).

@_jit
def _kalman(te, n, measured, in_range, sc, betas, beta0, tf, pf, t0, tm_prev, fault, started, error, faults):
    k = measured.shape[0]
    rows = te.shape[0]
    for j in range(rows):
        if started[0] == 0:
            for i in range(k):
                tf[i] = measured[i, j]
                t0[i] = measured[i, j]
                tm_prev[i] = measured[i, j]
                pf[i] = sc[i, 7]
                fault[i] = False
            started[0] = 1
        for i in range(k):
            tm = measured[i, j]
            tp = sc[i, 0] * tf[i] + sc[i, 2] * te[j] + sc[i, 3] * n[j] + sc[i, 4]
            pp = sc[i, 1] * pf[i] + sc[i, 5]
            if not in_range[i, j]:
                fault[i] = True
                tf[i] = tp
                pf[i] = pp
                faults[i, j] = True
                continue
            jump = abs(tm - tm_prev[i])
            tm_prev[i] = tm
            if not jump <= sc[i, 8]:
                fault[i] = True
            elif abs(tm - tp) <= sc[i, 9]:
                fault[i] = False
            if fault[i]:
                tf[i] = tp
                pf[i] = pp
            else:
                gain = pp / (pp + sc[i, 6])
                tf[i] = tp + gain * (tm - tp)
                pf[i] = pp - gain * pp
            faults[i, j] = fault[i]
        e = beta0
        for i in range(k):
            e = e + betas[i] * (tf[i] - t0[i])
        error[j] = e


class KalmanState:
    """What the block keeps between calls, for a run in chunks."""

    def __init__(self, k: int, f):
        self.f = f
        self.tf, self.pf, self.t0, self.tm_prev = (np.zeros(k, f) for _ in range(4))
        self.fault = np.zeros(k, np.bool_)
        self.started = np.zeros(1, np.int64)


def kalman(te, n, measured: list, in_range: list, sc: np.ndarray, betas: np.ndarray, beta0, f,
           state: KalmanState | None = None):
    """(error, faults (k, rows)) for these calls; state carries over when given."""
    rows = len(te)
    k = len(measured)
    state = state or KalmanState(k, f)
    error = np.empty(rows, f)
    faults = np.zeros((k, rows), np.bool_)
    stacked = np.empty((k, rows), f)
    for i, m in enumerate(measured):
        stacked[i] = m
    ranges = np.empty((k, rows), np.bool_)
    for i, r in enumerate(in_range):
        ranges[i] = r
    _kalman(np.ascontiguousarray(te, f), np.ascontiguousarray(n, f), stacked, ranges, np.ascontiguousarray(sc, f),
            np.ascontiguousarray(betas, f), f(beta0), state.tf, state.pf, state.t0, state.tm_prev, state.fault,
            state.started, error, faults)
    return error, faults


# ---------------------------------------------------------------------------------------------
# Input guard (models/safety.py::_hold). state_f = last, good; state_i = fault, count.

@_jit
def _hold(x, valid, is_range, ready_row, offset, settle, jump, state_f, state_i, held, faults):
    fault = state_i[0] != 0
    count = state_i[1]
    last = state_f[0]
    good = state_f[1]
    for jj in range(x.shape[0]):
        j = jj + offset
        ok = valid[jj]
        if is_range:
            fault = not ok
        elif j <= ready_row:
            fault = not ok
            count = 0
        elif not ok:
            fault = True
            count = 0
        elif not abs(x[jj] - last) <= jump:
            fault = True
            count = 0
        elif fault:
            count += 1
            if count >= settle:
                fault = False
                count = 0
        if ok and not is_range:
            last = x[jj]
        if not fault:
            good = x[jj]
        held[jj] = good
        faults[jj] = fault
    state_i[0] = 1 if fault else 0
    state_i[1] = count
    state_f[0] = last
    state_f[1] = good


class HoldState:
    def __init__(self, f):
        self.values = np.zeros(2, f)  # last, good: f(0) at the first call
        self.flags = np.zeros(2, np.int64)  # fault, count


def hold(x, valid, is_range: bool, ready_row: int, settle: int, jump, f, state: HoldState | None = None,
         offset: int = 0):
    """(held, faults) as safety._hold; offset is the row number of x[0] in the whole recording."""
    state = state or HoldState(f)
    rows = len(x)
    held = np.zeros(rows, f)
    faults = np.zeros(rows, np.bool_)
    _hold(np.ascontiguousarray(x, f), np.ascontiguousarray(valid, np.bool_), bool(is_range), np.int64(ready_row),
          np.int64(offset), np.int64(settle), f(jump), state.values, state.flags, held, faults)
    return held, faults


# ---------------------------------------------------------------------------------------------
# Output limiter (the loop over calls in models/safety.py::guarded_predict), one output.
# y[0] is the output of the previous call.

@_jit
def _limit(m, start, y_state, series, limited, clamped, invalid, real_max, step_max, step_min, out_max, out_min):
    y = y_state[0]
    for j in range(start, series.shape[0]):
        v = m[j - start]
        if not abs(v) <= real_max:
            invalid[j] = True
        else:
            delta = v - y
            if delta > step_max:
                y = y + step_max
                limited[j] = True
            elif delta < step_min:
                y = y + step_min
                limited[j] = True
            else:
                y = v
        if y > out_max:
            y = out_max
            clamped[j] = True
        elif y < out_min:
            y = out_min
            clamped[j] = True
        series[j] = y
    y_state[0] = y


def limit(model_values, start: int, y_state: np.ndarray, series, limited, clamped, invalid, constants: dict, f) -> None:
    """Rows start.. of series from model_values[0..]; flags OR-ed into limited/clamped/invalid."""
    _limit(np.ascontiguousarray(model_values, f), np.int64(start), y_state, series, limited, clamped, invalid,
           f(constants["c_RealMax"]), f(constants["c_StepMax"]), f(constants["c_StepMin"]),
           f(constants["c_OutMax"]), f(constants["c_OutMin"]))


# ---------------------------------------------------------------------------------------------
# Grey models (models/grey.py::predict_gm0n, predict_gm1n). temps: (k, rows).

@_jit
def _gm0n(temps, a, x1, b, sums, previous, out):
    k = temps.shape[0]
    for j in range(out.shape[0]):
        for i in range(k):
            sums[i] = sums[i] + temps[i, j]
        level = a
        for i in range(k):
            level = level + b[i] * sums[i]
        if j == 0:
            previous = level - x1
        out[j] = level - previous
        previous = level


@_jit
def _gm1n(temps, x1, keep, gain, b, sums, previous, out):
    k = temps.shape[0]
    for j in range(out.shape[0]):
        for i in range(k):
            sums[i] = sums[i] + temps[i, j]
        forced = b[0] * sums[0]
        for i in range(1, k):
            forced = forced + b[i] * sums[i]
        if j == 0:
            level = x1
        else:
            level = keep * previous + gain * forced
        out[j] = level - previous
        previous = level


def gm0n(temps: list, a, x1, b: list, f) -> np.ndarray:
    stacked = np.array(temps, f).reshape(len(temps), -1)
    out = np.empty(stacked.shape[1], f)
    _gm0n(stacked, f(a), f(x1), np.array(b, f), np.zeros(len(temps), f), f(0), out)
    return out


def gm1n(temps: list, x1, keep, gain, b: list, f) -> np.ndarray:
    stacked = np.array(temps, f).reshape(len(temps), -1)
    out = np.empty(stacked.shape[1], f)
    _gm1n(stacked, f(x1), f(keep), f(gain), np.array(b, f), np.zeros(len(temps), f), f(0), out)
    return out
