"""The fault hold (issue 61 item 4): while a sensor's fault bit is set, no output moves far.

A faulty sensor is held at its last good value (models/safety.py), but the model goes on computing from that
value while the machine moves: a Kalman block's open-loop bearing temperature drifted 35 um in 30 calls. So while
any input's fault bit is set, each limited output's model value is kept within `bound` of the value it had the
call before the fault began; the rate limiter then moves the output as usual. Per call and output, after the
model, the known start and the probe fusion, before the limiter (generator/fault_hold.py emits the same):

    if AnyFault:  if not Holding: Anchor := Last; Holding := TRUE
                  model := min(max(model, Anchor - Bound), Anchor + Bound)
    else:         Holding := FALSE
    if |model| <= REAL_MAX: Last := model

A block generated before the hold has no bound (`Limits.fault_move` None) and none of this.
"""
from __future__ import annotations

import numpy as np

from thermoplc.base import compiled

REAL_MAX = 3.402823e38


def apply(values: np.ndarray, any_fault: np.ndarray, bound: float, precision: str,
          state: np.ndarray | None = None) -> np.ndarray:
    """The model values held near their value before each fault; `state` (anchor, last, holding as 0/1) carries
    the block's memory from one chunk of calls to the next (models/streaming.py)."""
    f = np.float32 if precision == "f32" else np.float64
    values = np.ascontiguousarray(values, f)
    state = np.zeros(3, f) if state is None else state
    out = np.empty(len(values), f)
    loop = _apply if compiled.enabled(len(values)) else getattr(_apply, "py_func", _apply)
    loop(values, np.ascontiguousarray(any_fault, np.bool_), f(bound), f(REAL_MAX), state, out)
    return out


@compiled.jit
def _apply(values, any_fault, bound, real_max, state, out):
    anchor, last = state[0], state[1]
    holding = state[2] != 0
    for j in range(values.shape[0]):
        m = values[j]
        if any_fault[j]:
            if not holding:
                anchor = last
                holding = True
            high = anchor + bound
            low = anchor - bound
            if m > high:
                m = high
            elif m < low:
                m = low
        else:
            holding = False
        if abs(m) <= real_max:
            last = m
        out[j] = m
    state[0], state[1] = anchor, last
    state[2] = 1 if holding else 0
