"""The known start (issue 61): at a run's first call the block outputs the drift its runs started at.

Every target of a recording is a drift measured since the run's start, so at the block's first running call
(power-on, Reset) the true value is known: about 0. A fitted model is not: an intercept, a filter state or a
lag starts wherever the fit put it (FL_THERMAL's mlr: -14 um). The block therefore latches, at its first
call with a finite model value, the start offset `drift - model`, and lets it fade by `decay` per call, so
the output starts at the drift and joins the model as the model's own start error fades in the training
runs (fitting/start_fit.py fits the decay). Per call, in this order (generator/start.py emits the same):

    if not Latched: if |model| <= REAL_MAX: Offset := Drift - model; Latched := TRUE
    else:           Offset := Offset * Decay
    if |Offset| < FLOOR: Offset := 0      (a faded offset ends before it becomes subnormal)
    output: model + Offset   (then the probe fusion, if any, and the output limiter of every block)

A model value that is NaN or Inf at the first call latches nothing (the limiter holds the output); the
next finite one latches. Reset starts it afresh, as any other state.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thermoplc.base import compiled
from thermoplc.base.binary32 import FADE_FLOOR, REAL_TEXT_MAX, f32_hex, round_f32
from thermoplc.base.errors import UserError
from thermoplc.models.pair import check_section, constant_pair

MIN_DECAY = 1e-6  # a decay is 0 (the offset is gone after the first call) or at least this, so a product of
# an offset at the floor and the decay stays a normal number
FIELDS = ("drift_um", "decay")


@dataclass(frozen=True)
class Start:
    """The start's constants, each as (float64 fitted, binary32 the block holds)."""
    drift_um: tuple[float, float]
    decay: tuple[float, float]

    @staticmethod
    def of(drift_um: float, decay: float) -> "Start":
        return Start((float(drift_um), round_f32(float(drift_um))), (float(decay), round_f32(float(decay))))

    def value(self, name: str, precision: str = "f32") -> float:
        pair = getattr(self, name)
        return pair[0] if precision == "f64" else pair[1]

    def values(self) -> dict[str, float]:
        """The binary32 value of each constant the block declares (contract/constants.py names them)."""
        return {name: getattr(self, name)[1] for name in FIELDS}

    def to_doc(self) -> dict:
        return {name: {"f64": getattr(self, name)[0], "f32": f32_hex(getattr(self, name)[1])} for name in FIELDS}

    @staticmethod
    def from_doc(doc, path: str) -> "Start":
        """The model file's `start` section; every problem named by its field."""
        check_section(doc, path, "start", FIELDS, "a constant of the start")
        start = Start(*(constant_pair(doc[name], path, f"start.{name}") for name in FIELDS))
        if not (start.decay[1] == 0.0 or round_f32(MIN_DECAY) <= start.decay[1] < 1.0):
            raise UserError(f"{path}: field 'start.decay': {start.decay[0]!r}; expected a factor per call from "
                            f"{MIN_DECAY:g} to below 1, or 0 (the model's start error fades)")
        if not abs(start.drift_um[1]) <= 1e6:
            raise UserError(f"{path}: field 'start.drift_um': {start.drift_um[0]!r}; expected a drift within "
                            f"+-1e6 um")
        return start


def apply(start: Start, model_values: np.ndarray, precision: str, state: np.ndarray | None = None) -> np.ndarray:
    """The target with the start offset, per call from the block's first running call; `state` (offset,
    latched as 0/1) carries the block's memory from one chunk of calls to the next (models/streaming.py)."""
    f = np.float32 if precision == "f32" else np.float64
    values = np.ascontiguousarray(model_values, f)
    state = np.zeros(2, f) if state is None else state
    out = np.empty(len(values), f)
    compiled.route(_apply, len(values))(values, f(start.value("drift_um", precision)),
                                        f(start.value("decay", precision)), f(REAL_TEXT_MAX), f(FADE_FLOOR), f(0),
                                        state, out)
    return out


@compiled.jit
def _apply(values, drift, decay, real_max, floor, zero, state, out):
    offset = state[0]
    latched = state[1] != 0
    for j in range(values.shape[0]):
        m = values[j]
        if not latched:
            if abs(m) <= real_max:
                offset = drift - m
                latched = True
        else:
            offset = offset * decay
        if abs(offset) < floor:
            offset = zero
        out[j] = m + offset
    state[0] = offset
    state[1] = 1 if latched else 0
