"""verify --faults, the restarts: where a block's state starts afresh (its first running call, a Reset) and the data
around that call are what the state would carry on wrongly.

A block that forgets to start a state at Reset, or starts it wrong at its first call, passes every replay in
which the carried-on state and the fresh one agree: the recording's first call and the fault cases' Reset come
where nothing has moved. The cross-sensor check's slow means are such a state (models/plausibility.py): at a Reset
they restart at the current difference, and a block that carries them on agrees with one that restarts them
unless the difference moved since. So two cases move it on purpose:

- reset after a fault: a temperature reads off by a step until the slow mean has followed it (the check flags it,
  the fault hold holds the outputs); the PLC program pulses Reset at the call where that temperature differs most
  from what the others say, and from there on it reads off by what puts that difference between its swing gate
  and its level gate (a sensor swapped in the stop). A block that carries the mean on (the step in it) or leaves it
  where the Reset zeroed it (the whole difference beyond the swing gate) flags there; the model restarts the mean
  at that difference and does not.
- late start: the block is first enabled at the call where a temperature differs most from what the others say
  (relative to its swing gate). A block that starts the mean at zero rather than at that difference flags it.

Knows the models' relations (what the check computes), never the generator (the proof stays independent).
"""
from __future__ import annotations

import math

import numpy as np

from thermoplc.models.modelfile import Model
from thermoplc.models.plausibility import SWING_S

FOLLOWED_TIME_CONSTANTS = 3.0  # the slow mean has followed a step to within exp(-3) = 5 % of it
STEP_K = 5.0  # the step of a sensor read wrong: beyond any card's noise, inside every temperature range


def step_size_K(model: Model) -> float:
    """A step the swing test cannot take for a swing of the recording: three times the widest swing gate."""
    check = model.plausibility
    gates = [r.swing_K[0] for r in check.relations] if check is not None and check.swings else []
    return max(STEP_K, 3.0 * max(gates, default=0.0))


def step_calls(model: Model, settle_calls: int) -> int:
    """Calls a stepped reading lasts: the jump check accepts it after `settle_calls`, then the slow mean follows."""
    return int(settle_calls) + math.ceil(FOLLOWED_TIME_CONSTANTS * SWING_S / model.sample_period_s) + 1


def reset_after_step(values: np.ndarray, reset_row: int, calls: int, size: float, swapped: float
                     ) -> tuple[np.ndarray, np.ndarray, int]:
    """The column stepped by `size` for the `calls` calls before `reset_row` (from call 1 at the earliest), Reset
    pulsed at `reset_row`, and from there on off by `swapped`; returns the column, the Reset input and the step's
    first call."""
    first = max(1, reset_row - calls)
    out = np.array(values, np.float64)
    out[first:reset_row] += size
    out[reset_row:] += swapped
    reset = np.zeros(len(values), bool)
    reset[reset_row] = True
    return out.astype(np.float32), reset, first  # float32 -> float64 -> float32 leaves every other call as it was


def reset_rows(model: Model, inputs: dict, temperatures: list[str], calls: int, default: int
               ) -> dict[str, tuple[int, float]]:
    """Per temperature, the call of its Reset and how far it reads off from there on (a sensor swapped in the
    stop): the call where it differs most from what the others say (relative to its swing gate), after room for
    its step, and the offset that takes that difference midway between its swing gate and its level gate (1.5 times
    the swing gate without a level gate; none where the level gate is the narrower), so that a slow mean a Reset
    zeroes and does not restart shows, and the level test does not hide it; (`default`, 0) for a block without the
    swing test."""
    rows = len(next(iter(inputs.values())))
    earliest = min(calls + 1, rows - 1)
    out = {name: (default, 0.0) for name in temperatures}
    for relation, difference in _differences(model, inputs):
        swing = relation.swing_K[0]
        row = earliest + int(np.argmax(np.abs(difference[earliest:])))
        target = (swing + relation.gate_K[0]) / 2 if relation.gate_K is not None else 1.5 * swing
        d = float(difference[row])
        out[relation.sensor] = (row, math.copysign(1.0, d) * (target - abs(d)) if target > swing else 0.0)
    return out


def late_start_row(model: Model, inputs: dict) -> int | None:
    """The call (after the first) where some checked temperature differs most from what the others say, relative
    to its swing gate; None for a block without the swing test or data too short."""
    reaches = [np.abs(d) / r.swing_K[0] for r, d in _differences(model, inputs)]
    rows = len(next(iter(inputs.values())))
    if not reaches or rows < 2:
        return None
    return 1 + int(np.argmax(np.max(reaches, axis=0)[1:]))


def _differences(model: Model, inputs: dict) -> list[tuple]:
    """Per relation of a check with the swing test, the relation and its temperature's difference from what the
    others say per call (float64; NaN and Inf as 0)."""
    if model.plausibility is None or not model.plausibility.swings:
        return []
    out = []
    with np.errstate(invalid="ignore", over="ignore"):
        for r in model.plausibility.relations:
            expected = r.intercept[0] + sum(slope[0] * np.asarray(inputs[name], np.float64) for name, slope in r.slopes)
            difference = np.asarray(inputs[r.sensor], np.float64) - expected
            out.append((r, np.nan_to_num(difference, nan=0.0, posinf=0.0, neginf=0.0)))
    return out


def enabled_from(rows: int, start: int) -> np.ndarray:
    """Enable FALSE before call `start`, TRUE from it on: the block's first running call is `start`."""
    return np.arange(rows) >= start
