"""verify --faults, the restarts: where a block's state starts afresh (its first running call, a Reset) or carries
on over a pause, and the data around that call are what the state would carry on, or start, wrongly.

A block that forgets to start a state at Reset, or starts it wrong at its first call, passes every replay in
which the carried-on state and the fresh one agree: the recording's first call and the fault cases' Reset come
where nothing has moved. The cross-sensor check's slow means are such a state (models/plausibility.py): at a Reset
they restart at the current difference, over a pause they carry on, and a block that does the other agrees with
the model unless the difference moved since. So these cases move it on purpose, each at a call where every
input is inside its guard range (a block that is not Ready there starts nothing):

- reset-after, per temperature: it reads off by a step until the slow mean has followed it (the check flags it,
  the fault hold holds the outputs); the PLC program pulses Reset at the call where that temperature differs most
  from what the others say, and from there on it reads off by what puts that difference between its swing gate
  and its level gate (a sensor swapped in the stop). A block that carries the mean on (the step in it) or leaves
  it where the Reset zeroed it (the whole difference beyond the swing gate) flags there; the model does not.
- reset-far: a Reset after which the first checked temperature reads 1.5 times its level gate off, then comes
  back: the check flags at once (the fault hold starts from the state the Reset left), and the slow means start
  at the Reset, not once the reading is back.
- pause: Enable FALSE across the data's largest move of a difference from its slow mean that no jump check flags
  (the machine cooled while the block did not follow): a block that restarts its means there differs.
- pause-flagged: a temperature ramped beyond its gate and back, then Enable FALSE while SensorsDisagree waits
  for its settle calls: they count only on running calls.
- reset-stuck / pause-stuck: a temperature frozen until its stuck check fires, then a Reset (the repeat count
  starts again), or frozen with Enable FALSE one call in fifty (the count goes on over a pause).
- probe-reset / probe-pause (a fused block): a NaN probing and a held ProbeNew, then a Reset (the refusals and
  the suspicion start again); Enable FALSE between two probings (their spacing counts running calls).
- late-start: the block first Ready at the call where a temperature differs most from what the others say,
  enabled a few calls before with a temperature NaN. A block that starts the mean at zero rather than at that
  difference, or on a call that is not Ready, flags it.

Knows the models' relations (what the check computes), never the generator (the proof stays independent).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from thermoplc.contract.outputs import ENABLE_INPUT, PROBE_NEW_INPUT, PROBE_VALUE_INPUT, RESET_INPUT
from thermoplc.models.model import Model
from thermoplc.models.plausibility import SWING_S, relation_difference, swing_factors
from thermoplc.models.probing import rising
from thermoplc.models.safety import Limits, guards, in_range

FOLLOWED_TIME_CONSTANTS = 3.0  # the slow mean has followed a step to within exp(-3) = 5 % of it
STEP_K = 5.0  # the step of a sensor read wrong: beyond any card's noise, inside every temperature range
FAR_GATES = 1.5  # reset-far's difference, in level gates
PAUSE_S = 3600.0  # the longest pause searched
UNREADY_CALLS = 5  # late-start's calls enabled before every input is in range
FAR_CALLS = 30  # reset-far's calls at its offset before it comes back
STUCK_PAUSE_EVERY = 50  # pause-stuck: Enable FALSE one call in this many
TRANSIENT_PROBE_CALLS = 30  # probe-reset: calls ProbeNew is held TRUE
TRANSIENT_PAUSE_CALLS = 30  # pause-flagged's pause beyond the settle calls
PAUSE_WORK = 20_000_000  # calls x pause lengths searched for the largest pause (a few seconds of numpy)


@dataclass(frozen=True)
class Restart:
    """One case: the columns it changes, the Enable/Reset inputs it drives, its calls, and the temperature whose
    fault bit counts as flagging it (None: Ready/ENO only)."""
    name: str
    description: str
    what: str
    first: int
    last: int
    columns: dict = field(default_factory=dict)
    control: dict = field(default_factory=dict)
    sensor: str | None = None


def restart_cases(model: Model, inputs: dict, temperatures: list[str], declared: set, limits: Limits,
                  default_row: int, probing: dict | None = None) -> tuple[list[Restart], list[str]]:
    """The restart cases for a block with the inputs `declared` (Enable/Reset), on the fault-free `inputs` (and the
    scheduled `probing` of a fused block); `default_row`: where a case that needs no particular call begins. Returns
    the cases and, for each case the data are too short for, why it was not run."""
    rows = len(next(iter(inputs.values())))
    if rows < 3:
        return [], [f"every restart case: {rows} calls"]
    valid = _all_valid(model, inputs, limits)
    differences = _differences(model, inputs, valid)
    cases: list[Restart | str] = []
    if RESET_INPUT in declared:
        cases += _reset_after(model, inputs, temperatures, limits, differences, default_row)
        cases += _reset_far(inputs, differences, limits)
        cases += _stuck(inputs, temperatures, limits, default_row, RESET_INPUT)
        cases += _probe_reset(probing, default_row) if probing else []
    if ENABLE_INPUT in declared:
        cases += _pause(model, inputs, limits, differences, valid)
        cases += _pause_flagged(inputs, differences, limits, default_row)
        cases += _stuck(inputs, temperatures, limits, default_row, ENABLE_INPUT)
        cases += _probe_pause(probing, default_row) if probing else []
        cases += _late_start(inputs, differences)
    return [c for c in cases if isinstance(c, Restart)], [c for c in cases if isinstance(c, str)]


def step_size_K(model: Model) -> float:
    """A step the swing test cannot take for a swing of the recording: three times the widest swing gate."""
    check = model.plausibility
    gates = [r.swing_K[0] for r in check.relations] if check is not None and check.swings else []
    return max(STEP_K, 3.0 * max(gates, default=0.0))


def step_calls(model: Model, settle_calls: int) -> int:
    """Calls a stepped reading lasts: the jump check accepts it after `settle_calls`, then the slow mean follows."""
    return int(settle_calls) + math.ceil(FOLLOWED_TIME_CONSTANTS * SWING_S / model.sample_period_s) + 1


def _reset_after(model: Model, inputs: dict, temperatures: list[str], limits: Limits, differences: dict,
                 default_row: int) -> list:
    rows = len(next(iter(inputs.values())))
    size, calls = step_size_K(model), step_calls(model, limits.settle_calls)
    earliest = min(calls + 1, rows - 1)
    cases = []
    for name in temperatures:
        row, swapped = min(default_row, rows - 1), 0.0
        relation, difference = differences.get(name, (None, None))
        if relation is not None and relation.swing_K is not None and np.isfinite(difference[earliest:-1]).any():
            row = earliest + int(np.nanargmax(np.abs(difference[earliest:-1])))  # a call after the Reset
            swing = relation.swing_K[0]
            target = (swing + relation.gate_K[0]) / 2 if relation.gate_K is not None else 1.5 * swing
            d = float(difference[row])
            swapped = math.copysign(1.0, d) * (target - abs(d)) if target > swing else 0.0
        first = max(1, row - calls)
        if row - first < calls or row >= rows - 1:
            cases.append(f"reset-after on {name}: a step of {calls} calls, a Reset and a call after it need "
                         f"{calls + 3} calls")
            continue
        column = np.array(inputs[name], np.float64)
        column[first:row] += size
        column[row:] += swapped
        cases.append(Restart("reset-after", f"+{size:.3g}K {row - first} calls, Reset" +
                             (f", {swapped:+.2g}K on" if swapped else ""), name, first,
                             rows - 1 if swapped else row, {name: column.astype(np.float32)},
                             {RESET_INPUT: _at(rows, row)}, name))
    return cases


def _reset_far(inputs: dict, differences: dict, limits: Limits) -> list[Restart]:
    """A Reset after which the first checked temperature with a level gate reads FAR_GATES gates off for
    FAR_CALLS calls, then comes back at half the jump limit per call: the check flags from the Reset on, the fault
    hold starts from what the Reset left, and the slow means start at the Reset (not once the reading is back)."""
    rows = len(next(iter(inputs.values())))
    levelled = [(r, d) for r, d in differences.values() if r.gate_K is not None and np.isfinite(d[1:]).any()]
    if not levelled:
        return []
    relation, difference = levelled[0]
    row = 1 + int(np.nanargmax(np.abs(difference[1:])))
    d = float(difference[row])
    offset = math.copysign(1.0, d) * (FAR_GATES * relation.gate_K[0] - abs(d))
    back = np.linspace(offset, 0.0, math.ceil(abs(offset) / (0.5 * limits.max_jump_K)) + 1)
    shape = np.concatenate([np.full(FAR_CALLS, offset), back])[:rows - row]
    column = np.array(inputs[relation.sensor], np.float64)
    column[row:row + len(shape)] += shape
    return [Restart("reset-far", f"Reset, {offset:+.2g}K past gate, back", relation.sensor, row,
                    min(row + len(shape), rows - 1), {relation.sensor: column.astype(np.float32)},
                    {RESET_INPUT: _at(rows, row)}, relation.sensor)]


def _pause(model: Model, inputs: dict, limits: Limits, differences: dict, valid: np.ndarray) -> list[Restart]:
    """Enable FALSE from call a to b - 1 (at most PAUSE_S), where some checked temperature's difference at b is
    furthest from its slow mean before the pause, relative to its swing gate, with every input valid at a - 1 and
    b and no checked temperature moved further than the jump check allows (a larger move is a fault, and the held
    value would hide the restart)."""
    swinging = [(r, d) for r, d in differences.values() if r.swing_K is not None]
    rows = len(valid)
    if not swinging:
        return []
    keep, alpha = swing_factors(model.sample_period_s, "f64")
    readings = np.array([np.asarray(inputs[r.sensor], np.float64) for r, _ in differences.values()])
    longest = max(1, min(math.ceil(PAUSE_S / model.sample_period_s), rows // 4, PAUSE_WORK // rows))
    best, where = -1.0, None
    for relation, difference in swinging:
        filled = np.nan_to_num(difference)
        mean = lfilter([alpha], [1.0, -keep], filled, zi=[keep * filled[0]])[0]  # after each call
        for g in range(2, min(longest + 2, rows)):  # the last call before the pause i, the next running call i + g
            with np.errstate(invalid="ignore"):
                reach = np.abs(difference[g:] - mean[:rows - g]) / relation.swing_K[0]
                moved = np.max(np.abs(readings[:, g:] - readings[:, :rows - g]), axis=0)
            reach[~((moved <= limits.max_jump_K) & valid[g:] & valid[:rows - g])] = -1.0
            i = int(np.argmax(reach))
            if reach[i] > best:
                best, where = float(reach[i]), (i + 1, i + g)
    if where is None or best < 0:
        return []
    a, b = where
    return [Restart("pause", f"Enable FALSE calls {a}..{b - 1}", ENABLE_INPUT, a, b,
                    control={ENABLE_INPUT: _enabled_but(rows, a, b)})]


def _pause_flagged(inputs: dict, differences: dict, limits: Limits, first: int) -> list:
    """The first checked temperature with a level gate ramped (at half the jump limit per call) to twice its gate
    beyond what the others say and back, then Enable FALSE for the settle calls and more while SensorsDisagree
    waits for them: a block whose check runs while disabled counts them and clears the bit early."""
    levelled = [(r, d) for r, d in differences.values() if r.gate_K is not None]
    rows = len(next(iter(inputs.values())))
    if not levelled or first < 1:
        return []
    relation, difference = levelled[0]
    height = 2.0 * (relation.gate_K[0] + abs(float(np.nan_to_num(difference[first]))))
    ramp = np.linspace(0.0, height, math.ceil(height / (0.5 * limits.max_jump_K)) + 1)
    shape = np.concatenate([ramp, ramp[::-1]])
    needed = len(shape) + int(limits.settle_calls) + TRANSIENT_PAUSE_CALLS + 2
    first = min(first, rows - needed)
    if first < 1:
        return [f"pause-flagged on {relation.sensor}: a ramp, its settle calls and a pause need {needed + 1} calls"]
    end = first + len(shape)
    column = np.array(inputs[relation.sensor], np.float64)
    column[first:end] += shape
    back = end + int(limits.settle_calls) + TRANSIENT_PAUSE_CALLS
    return [Restart("pause-flagged", f"ramp {height:.2g}K, back, off {back - end} calls", relation.sensor, first,
                    back, {relation.sensor: column.astype(np.float32)},
                    {ENABLE_INPUT: _enabled_but(rows, end, back)}, relation.sensor)]


def _late_start(inputs: dict, differences: dict) -> list[Restart]:
    """Enabled UNREADY_CALLS calls before the call of the largest difference, the first checked temperature NaN on
    those: the block runs but is not Ready, and starts at that call (a block that starts its means, or its model, on
    a call that is not Ready, or reads no fault there, differs)."""
    reaches = [np.abs(d) / r.swing_K[0] for r, d in differences.values() if r.swing_K is not None]
    if not reaches:
        return []
    reach = np.fmax.reduce(reaches)
    if not np.isfinite(reach[1:]).any():
        return []
    ready = 1 + int(np.nanargmax(reach[1:]))
    start = max(1, ready - UNREADY_CALLS)
    rows = len(reach)
    sensor = next(iter(differences))
    column = np.array(inputs[sensor], np.float32)
    column[start:ready] = np.nan
    return [Restart("late-start", f"on at {start}, {sensor} NaN {ready - start} calls", ENABLE_INPUT, start,
                    min(ready + 30, rows - 1), {sensor: column}, {ENABLE_INPUT: np.arange(rows) >= start}, sensor)]


def _stuck(inputs: dict, temperatures: list[str], limits: Limits, default_row: int, control: str) -> list:
    """The first temperature frozen to the end. With Reset: a Reset once its stuck check has fired and the count
    stands at its cap (the count starts again there). With Enable: Enable FALSE for one call in every
    STUCK_PAUSE_EVERY (a PLC program that pauses the block now and then): the count goes on over a pause."""
    rows = len(next(iter(inputs.values())))
    if limits.stuck_calls is None or not temperatures:
        return []
    name, calls = temperatures[0], int(limits.stuck_calls)
    label = "reset-stuck" if control == RESET_INPUT else "pause-stuck"
    frozen_at = min(default_row, rows - 2 * calls - 6)  # fired, reset, and room to fire again after the Reset
    if frozen_at < 1:
        return [f"{label} on {name}: a stuck check of {calls} calls needs {2 * calls + 7} calls"]
    column = np.array(inputs[name], np.float32)
    column[frozen_at:] = column[frozen_at]
    if control == RESET_INPUT:
        row = frozen_at + calls + 2
        return [Restart(label, f"frozen from {frozen_at}, Reset at {row}", name, frozen_at, rows - 1,
                        {name: column}, {RESET_INPUT: _at(rows, row)}, name)]
    calls_since = np.arange(rows) - frozen_at
    enable = ~((calls_since > 0) & (calls_since % STUCK_PAUSE_EVERY == 0))
    return [Restart(label, f"frozen from {frozen_at}, off 1 in {STUCK_PAUSE_EVERY}", name, frozen_at, rows - 1,
                    {name: column}, {ENABLE_INPUT: enable}, name)]


def _probe_reset(probing: dict, default_row: int) -> list:
    """A fused block's probings: one NaN (refused, counted), the next with ProbeNew held TRUE for
    TRANSIENT_PROBE_CALLS calls (ProbeSuspect), then a Reset: the count and the suspicion start again."""
    edges = _edges(probing, default_row)
    rows = len(probing[PROBE_NEW_INPUT])
    if len(edges) < 3 or edges[1] + TRANSIENT_PROBE_CALLS + 1 >= rows:
        return ["probe-reset: two probings and a Reset after them need more calls"]
    value, new = np.array(probing[PROBE_VALUE_INPUT], np.float32), np.array(probing[PROBE_NEW_INPUT], bool)
    value[edges[0]:edges[1]] = np.nan
    held_to = edges[1] + TRANSIENT_PROBE_CALLS
    new[edges[1]:held_to] = True
    return [Restart("probe-reset", f"NaN at {edges[0]}, held at {edges[1]}, Reset", PROBE_VALUE_INPUT, edges[0],
                    held_to, {PROBE_VALUE_INPUT: value, PROBE_NEW_INPUT: new}, {RESET_INPUT: _at(rows, held_to)})]


def _probe_pause(probing: dict, default_row: int) -> list:
    """Enable FALSE from just after one probing to just before the next: the probings' spacing counts running
    calls only (a block that counts disabled calls takes as scheduled what the model refuses as too soon)."""
    edges = _edges(probing, default_row)
    rows = len(probing[PROBE_NEW_INPUT])
    if len(edges) < 2 or edges[1] - edges[0] < 8:
        return ["probe-pause: two probings more than 8 calls apart after the sensor faults' start"]
    a, b = edges[0] + 3, edges[1] - 3
    return [Restart("probe-pause", f"Enable FALSE calls {a}..{b - 1}", ENABLE_INPUT, a, edges[1],
                    control={ENABLE_INPUT: _enabled_but(rows, a, b)})]


def _edges(probing: dict, default_row: int) -> np.ndarray:
    """The scheduled probings' rising edges from `default_row` on."""
    edges = np.flatnonzero(rising(probing[PROBE_NEW_INPUT]))
    return edges[edges >= default_row]


def _all_valid(model: Model, inputs: dict, limits: Limits) -> np.ndarray:
    """Per call, whether every input is inside its guard range (the block is Ready there)."""
    plan = guards(model)
    valid = np.ones(len(next(iter(inputs.values()))), bool)
    for flags in in_range(plan, {g.name: np.asarray(inputs[g.name], np.float32) for g in plan}, limits.values(),
                          np.float32).values():
        valid &= flags
    return valid


def _differences(model: Model, inputs: dict, valid: np.ndarray) -> dict:
    """Per checked temperature, its relation and its difference from what the others say per call (float64; NaN
    where some input is outside its guard range)."""
    if model.plausibility is None:
        return {}
    out = {}
    with np.errstate(invalid="ignore", over="ignore"):
        for r in model.plausibility.relations:
            difference = relation_difference(r, inputs, "f64")
            out[r.sensor] = (r, np.where(valid & np.isfinite(difference), difference, np.nan))
    return out


def _enabled_but(rows: int, first: int, end: int) -> np.ndarray:
    """Enable per call: FALSE from call `first` to `end` - 1."""
    calls = np.arange(rows)
    return (calls < first) | (calls >= end)


def _at(rows: int, row: int) -> np.ndarray:
    pulse = np.zeros(rows, bool)
    pulse[row] = True
    return pulse
