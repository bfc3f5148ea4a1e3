"""The per-call loops of the float32/float64 references: here the safety logic's (the stuck-reading count, the
input guard of safety._hold and the limiter of safety.guarded_predict); each kind's own loop sits in its module
(kalman._kalman, grey._gm0n and _gm1n, lumped_kernel._lumped). Each is written once: numba compiles it with
fast-math off (no FMA contraction, no reassociation, IEEE division and NaN semantics), or it runs as Python on
numpy scalars, as base/compiled.py's `route` decides; both give the same bits (tests/test_fast_reference.py).
They never see the emitted ST: the proof still compares two independent computations (the model's loop, the
block's own ST -> C translation in verifier/engines/native.py).

Rules that keep every value bit-identical whichever way the loop runs:
- every array and every scalar argument has the precision's dtype (float32 or float64), so
  numba types each operation in that precision: float32 * float32 -> float32, rounded per
  operation as numpy float32 scalars are;
- no Python float literal appears in arithmetic (a literal is float64 and would promote);
- state lives in small arrays the caller passes in, so a recording can be run chunk by chunk
  with the same result as in one piece.

They run as Python when numba is missing, under THERMOPLC_REFERENCE=slow, or while a process has asked for few
calls (base/compiled.py's `enabled()`).
"""
from __future__ import annotations

import numpy as np

from thermoplc.base import compiled
from thermoplc.base.compiled import jit

# ---------------------------------------------------------------------------------------------
# Stuck reading: per call, whether a temperature has repeated its last reading in range `stuck` calls in a
# row, and that last reading (models/safety.py::stuck_readings). state_f = last reading in range; state_i = repeats.

@jit
def _repeats(x, valid, stuck, state_f, state_i, out, lasts):
    last = state_f[0]
    same = state_i[0]
    for j in range(x.shape[0]):
        if valid[j]:
            if x[j] == last:
                if same < stuck:
                    same += 1
            else:
                same = 0
            last = x[j]
        out[j] = same >= stuck
        lasts[j] = last
    state_f[0] = last
    state_i[0] = same


class RepeatState:
    def __init__(self, f):
        self.values = np.zeros(1, f)  # the last reading in range: f(0) at the first call
        self.counts = np.zeros(1, np.int64)  # repeats of it


def repeats(x, valid, stuck: int, f, state: RepeatState | None = None):
    """Per call, whether the reading is stuck (`stuck` repeats of the last in-range reading) and that last
    in-range reading (the block's LastIn_i)."""
    state = state or RepeatState(f)
    out = np.zeros(len(x), np.bool_)
    lasts = np.zeros(len(x), f)
    compiled.route(_repeats, len(x))(np.ascontiguousarray(x, f), np.ascontiguousarray(valid, np.bool_), np.int64(stuck), state.values,
         state.counts, out, lasts)
    return out, lasts


# ---------------------------------------------------------------------------------------------
# Input guard (models/safety.py::_hold). state_f = last, good; state_i = fault, count.

@jit
def _hold(x, valid, stuck, is_range, ready_row, offset, settle, jump, state_f, state_i, held, faults):
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
        elif stuck[jj]:
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


def hold(x, valid, stuck, is_range: bool, ready_row: int, settle: int, jump, f, state: HoldState | None = None,
         offset: int = 0):
    """(held, faults) as safety._hold; stuck: per call, the reading is stuck (`repeats`); offset is the row number
    of x[0] in the whole recording."""
    state = state or HoldState(f)
    rows = len(x)
    held = np.zeros(rows, f)
    faults = np.zeros(rows, np.bool_)
    compiled.route(_hold, rows)(np.ascontiguousarray(x, f), np.ascontiguousarray(valid, np.bool_), np.ascontiguousarray(stuck, np.bool_),
                                bool(is_range), np.int64(ready_row), np.int64(offset), np.int64(settle), f(jump),
                                state.values, state.flags, held, faults)
    return held, faults


# ---------------------------------------------------------------------------------------------
# Output limiter (the loop over calls in models/safety.py::guarded_predict), one output.
# y[0] is the output of the previous call.

@jit
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
    compiled.route(_limit, len(series) - start)(
        np.ascontiguousarray(model_values, f), np.int64(start), y_state, series, limited, clamped, invalid,
        f(constants["real_max"]), f(constants["step_max"]), f(constants["step_min"]), f(constants["out_max"]),
        f(constants["out_min"]))
