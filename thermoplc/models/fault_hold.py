"""The fault hold (issue 61 item 4): while a sensor's fault bit is set, no output moves far.

A faulty sensor is held at its last good value (models/safety.py), but the model goes on computing from that
value while the machine moves: a Kalman block's open-loop bearing temperature drifted 35 um in 30 calls. So while
any input's fault bit is set, each limited output's model value is kept within `bound` of an anchor: the value
it had the call before the fault began, fading towards 0 (no compensation) by `fade` per call. A short fault
moves the axis little; a sensor that died leaves the block at no compensation, never held at a value the
machine has long left (FL_THERMAL: a frozen hold ended 91 um from the drift where no compensation is 71 um).
Per call and output, after the model and the known start, before the probe fusion (so probings still correct
a held model) and the limiter (generator/fault_hold.py emits the same):

    if AnyFault:  if not Holding: Anchor := Last; Holding := TRUE  else: Anchor := Anchor * Fade
                  model := min(max(model, Anchor - Bound), Anchor + Bound)
    else:         Holding := FALSE
    if |model| <= REAL_MAX: Last := model

A block generated before the hold has no bound (`Limits.fault_move` None) and none of this.
"""
from __future__ import annotations

import numpy as np

from thermoplc.base import compiled
from thermoplc.base.binary32 import FADE_FLOOR, REAL_TEXT_MAX



def apply(values: np.ndarray, any_fault: np.ndarray, bound: float, fade: float, precision: str,
          state: np.ndarray | None = None) -> np.ndarray:
    """The model values held near their value before each fault; `state` (anchor, last, holding as 0/1) carries
    the block's memory from one chunk of calls to the next (models/streaming.py)."""
    f = np.float32 if precision == "f32" else np.float64
    values = np.ascontiguousarray(values, f)
    state = np.zeros(3, f) if state is None else state
    out = np.empty(len(values), f)
    compiled.route(_apply, len(values))(values, np.ascontiguousarray(any_fault, np.bool_), f(bound), f(fade),
                                        f(REAL_TEXT_MAX), f(FADE_FLOOR), f(0), state, out)
    return out


@compiled.jit
def _apply(values, any_fault, bound, fade, real_max, floor, zero, state, out):
    anchor, last = state[0], state[1]
    holding = state[2] != 0
    for j in range(values.shape[0]):
        m = values[j]
        if any_fault[j]:
            if not holding:
                anchor = last
                holding = True
            else:
                anchor = anchor * fade
                if abs(anchor) < floor:
                    anchor = zero
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
