"""What every block does around its model so that it is safe on a machine (docs/reliability.md).

Input guards: a reading that is NaN or outside its range (a broken PT100 reads 3276.7 or -3276.8)
or, for temperatures, jumps by more than a limit in one call or repeats its reading for `stuck_calls` calls
in a row (a frozen card: models/envelope.py says how long is too long) marks its sensor faulty; the block
then holds the last good value (the Kalman filter instead sets that sensor's gain to 0) and takes
the sensor back after it has read steadily for a number of calls. The model starts at the first
call on which every input is in range. Output limits: each output moves at most `max_step` per
call and stays within +-`max_output`; K0 for SINUMERIK SD43900 is the limited error in mm with the
opposite sign. This module is the float32 reference of that logic; generator/safety.py emits the
same operations in the same order.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from thermoplc.base.binary32 import FADE_FLOOR, REAL_TEXT_MAX
from thermoplc.base.errors import UserError
from thermoplc.models import fault_hold, kernels
from thermoplc.models.envelope import data_limits, stuck_limit
from thermoplc.models.kind import fault_key, guard_kind
from thermoplc.models.kinds import kind_of
from thermoplc.models.model import Model
from thermoplc.models.plausibility import DISAGREE, CheckState, disagree
from thermoplc.models.probing import fused_core

LIMIT_MAX = 1.0e12  # far beyond any machine, far below FLT_MAX
K0_MM_PER_UM = -0.001  # K0 opposes the predicted error: the NC moves the axis back by it


# The reference's keys for what the safety logic takes and reports per call besides the model's own
# outputs: no ST names (a colon is in no identifier), the block's names are contract/outputs.py's.
ENABLE, RESET = "control:enable", "control:reset"  # the commissioning inputs
CONTROL_START = {ENABLE: True, RESET: False}  # their values when the PLC program leaves them unwired
ENABLED, READY, LIMITED, CLAMPED, INVALID = (f"status:{name}" for name in ("enabled", "ready", "limited", "clamped",
                                                                            "invalid"))


def k0_key(axis: int) -> str:
    """The key of the K0 (SD43900, mm) of the `axis`-th output in um, counted from 1."""
    return f"k0:{axis}"


@dataclass(frozen=True)
class Limits:
    """Commissioning settings of the safety logic (generate --max-offset-um ... )."""
    max_output: float = 300.0  # um (urad for angle outputs)
    max_step: float = 2.0  # um per call
    temp_min_C: float = -40.0
    temp_max_C: float = 150.0
    max_speed_rpm: float = 100000.0
    max_other: float = 1.0e6  # feed, tool length and other non-temperature inputs
    max_jump_K: float = 1.0  # temperature change per call that marks a sensor faulty
    settle_calls: int = 30  # steady calls after which a held sensor is trusted again
    stuck_calls: int | None = 240  # a temperature repeating its reading this many calls in a row is stuck; None: a
    # block generated before the stuck check (the default: 1 h at 15 s, for a model file without an envelope)
    fault_move: float | None = 2.0  # um: while a fault bit is set each output stays this near (models/fault_hold.py);
    # None: a block generated before the hold
    fault_fade: float = 0.995  # per call, the held value's factor towards no compensation (generate --fault-fade-s)
    origins: tuple[tuple[str, str], ...] = ()  # (field, how it was chosen) for limits taken from the recording

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "origins":
                continue
            if value is None and f.name in ("fault_move", "stuck_calls"):
                continue
            if f.name == "fault_fade":
                if not (np.isfinite(value) and 0 < value <= 1 and float(np.float32(value)) >= 1e-6):
                    raise UserError(f"safety limit fault_fade must be a factor per call above 0 and at most 1, got "
                                    f"{value}")
                continue
            if not np.isfinite(value) or np.float32(value) <= 0 and f.name not in ("temp_min_C",):
                raise UserError(f"safety limit {f.name} must be a positive finite number (as a REAL), got {value}")
            if abs(value) > LIMIT_MAX:  # a block constant: must stay a finite REAL, with room for the arithmetic
                raise UserError(f"safety limit {f.name} must be within +-{LIMIT_MAX:g}, got {value}")
        if self.temp_min_C >= self.temp_max_C:
            raise UserError(f"temperature range {self.temp_min_C}..{self.temp_max_C} degC is empty")
        if not 1 <= self.settle_calls <= 10000:
            raise UserError(f"settle calls must be 1..10000, got {self.settle_calls}")
        if self.stuck_calls is not None and not (isinstance(self.stuck_calls, int) and 2 <= self.stuck_calls <= 32767):
            raise UserError(f"stuck calls must be a whole number 2..32767, got {self.stuck_calls}")

    def values(self) -> dict:
        """The values the safety logic computes with (key -> binary32 value or INT); the block holds
        each as a named constant (contract/constants.py names them)."""
        f = lambda x: float(np.float32(x))
        return {"temp_min": f(self.temp_min_C), "temp_max": f(self.temp_max_C),
                "speed_min": f(-self.max_speed_rpm), "speed_max": f(self.max_speed_rpm),
                "other_min": f(-self.max_other), "other_max": f(self.max_other),
                "jump_max": f(self.max_jump_K), "settle_calls": int(self.settle_calls), "one_call": 1,
                **({"stuck_calls": int(self.stuck_calls)} if self.stuck_calls is not None else {}),
                "step_max": f(self.max_step), "step_min": f(-self.max_step),
                "out_max": f(self.max_output), "out_min": f(-self.max_output), "k0_mm": f(K0_MM_PER_UM),
                "real_max": f(REAL_TEXT_MAX), **({"fault_move": f(self.fault_move), "fault_fade": f(self.fault_fade), "fault_floor": f(FADE_FLOOR)}
                   if self.fault_move else {})}

    @classmethod
    def for_model(cls, model: Model, **given) -> "Limits":
        """The limits `generate` uses for `model`: each one given (not None), else the clamp, rate limit, speed guard
        and stuck time from the model's envelope of its recording (models/envelope.py), else the defaults above."""
        chosen = (data_limits(model.envelope, model.sample_period_s) if model.envelope is not None
                  else {"stuck_calls": stuck_limit(None, model.sample_period_s)})
        if not model.signals("speed"):  # no speed guard in the block: nothing to take or to give
            chosen.pop("max_speed_rpm", None)
            if given.get("max_speed_rpm") is not None:
                raise UserError(f"--max-speed-rpm {given['max_speed_rpm']:g}: the model reads no speed input, so the "
                                f"block has no speed guard; leave the option out")
        if not stuck_checked(model):  # no temperature input: nothing to take or to give
            chosen.pop("stuck_calls", None)
            if given.get("stuck_calls") is not None:
                raise UserError(f"--stuck-calls {given['stuck_calls']}: the model reads no temperature input, so the "
                                f"block has no stuck check; leave the option out")
        taken = {name: chosen[name] for name in chosen if given.get(name) is None}
        return cls(**{name: value for name, value in given.items() if value is not None},
                   **{name: limit.value for name, limit in taken.items()},
                   origins=tuple((name, limit.why) for name, limit in taken.items()))

    def origin(self, name: str) -> str:
        """How the limit `name` (a field) was chosen, '' when given or the default."""
        return dict(self.origins).get(name, "")

    @classmethod
    def from_values(cls, given: dict) -> "Limits":
        """The limits whose `values()` these are (a key not given keeps its default)."""
        fields_of = {"temp_min": "temp_min_C", "temp_max": "temp_max_C", "speed_max": "max_speed_rpm",
                     "other_max": "max_other", "jump_max": "max_jump_K", "settle_calls": "settle_calls",
                     "stuck_calls": "stuck_calls",
                     "step_max": "max_step", "out_max": "max_output", "fault_move": "fault_move",
                     "fault_fade": "fault_fade"}
        return cls(**{"fault_move": None, "stuck_calls": None,
                      **{field: given[key] for key, field in fields_of.items() if key in given}})


@dataclass(frozen=True)
class Guard:
    """How one block input is checked. kind: 'fused' (the model's own fault logic decides, Kalman),
    'temperature' (range and jump, hold last good), 'range' (range only, hold last good)."""
    name: str
    index: int  # 1-based position among the block inputs
    kind: str
    low: str  # constant names of the valid range
    high: str


def guards(model: Model) -> tuple[Guard, ...]:
    out = []
    for k, s in enumerate(model.inputs, start=1):
        kind = guard_kind(s.role, kind_of(model.kind).fused_guards)
        if kind != "range":
            out.append(Guard(s.name, k, kind, "temp_min", "temp_max"))
        elif "speed" in s.role.split(","):
            out.append(Guard(s.name, k, "range", "speed_min", "speed_max"))
        else:
            out.append(Guard(s.name, k, "range", "other_min", "other_max"))
    return tuple(out)


def stuck_checked(model: Model) -> list[str]:
    """The inputs the block checks for a stuck reading: every temperature."""
    return [g.name for g in guards(model) if g.kind in ("temperature", "fused")]


NEVER_STUCK = 2 ** 62  # repeats counted for a block generated before the stuck check: none is ever enough


def stuck_readings(x: np.ndarray, valid: np.ndarray, limits: Limits, f, state=None) -> tuple[np.ndarray, np.ndarray]:
    """Per call, whether a temperature has repeated its last reading in range `limits.stuck_calls` times in a row
    (never, for a block generated before the check), and that last reading in range (what the cross-sensor check
    reads of a temperature a filter judges itself); `state` carries both from one chunk to the next."""
    stuck = NEVER_STUCK if limits.stuck_calls is None else limits.stuck_calls
    return kernels.repeats(x, valid, stuck, f, state)


def limited_outputs(core: dict) -> list[str]:
    """The model outputs the limiter acts on: every REAL one, in the model's order."""
    return [name for name, values in core.items() if np.asarray(values).dtype.kind == "f"]


def axis_outputs(model: Model, names: list[str]) -> list[str]:
    """Outputs in um: each gets a K0 for SD43900."""
    units = {model.target.name: model.target.unit}
    units.update({t["name"]: t["unit"] for t in model.settings.get("targets", ())})
    return [n for n in names if units.get(n, "um") == "um"]


def _hold(x: np.ndarray, valid: np.ndarray, stuck: np.ndarray, guard: Guard, ready_row: int, limits: Limits, f):
    """Last good value and fault flag per call, as the guard region computes them; `stuck`: per call, whether the
    reading is stuck (stuck_readings)."""
    return kernels.hold(x, valid, stuck, guard.kind == "range", ready_row, limits.settle_calls, limits.max_jump_K, f)


def held_while_faulty(core: dict | None, names: list[str], flags: dict, start: int, limits: Limits, precision: str,
                      states: dict | None = None) -> dict | None:
    """The model values `names` of `core` (from call `start` on) held near their value before each fault while
    any fault bit of `flags` is set (models/fault_hold.py); before the fusion, so probings still correct a held
    model. `states`: each name's hold state carried from one chunk of calls to the next (models/streaming.py)."""
    if core is None or limits.fault_move is None:
        return core
    any_fault = np.logical_or.reduce([np.asarray(v, bool) for v in flags.values()])[start:]
    return {**core, **{name: fault_hold.apply(core[name], any_fault, limits.fault_move, limits.fault_fade, precision,
                                              None if states is None else states[name]) for name in names}}


def sensors_disagree(model: Model, held: dict, start: int, limits: Limits, precision: str,
                     state: CheckState | None = None) -> dict:
    """The plausibility check's status bit per call under DISAGREE (none for a model without the check): the held
    readings compared from call `start` on, the block's first running call (models/plausibility.py); `state`
    carries it from one chunk of calls to the next."""
    if model.plausibility is None:
        return {}
    rows = len(next(iter(held.values())))
    flag = np.zeros(rows, bool)
    if start < rows:
        flag[start:] = disagree(model.plausibility, {name: held[name][start:] for name in model.plausibility.sensors()},
                                limits.settle_calls, model.sample_period_s, precision, state)
    return {DISAGREE: flag}


def checked_values(plan, core_inputs: dict, repeated: dict) -> dict:
    """Per temperature, the value the cross-sensor check reads: the block's held value (Good_i), or for one a filter
    judges itself its last reading in range (LastIn_i; `repeated`: stuck_readings' pair per temperature)."""
    return {g.name: repeated[g.name][1] if g.kind == "fused" else core_inputs[g.name]
            for g in plan if g.kind != "range"}


def fault_flags(plan, valid: dict, faults: dict, core: dict | None, start: int) -> dict:
    """Each input's fault flag per call, under fault_key(input): the guard's flag, or for a fused input
    its range check before the model starts (call `start`) and the filter's verdict after."""
    out = {}
    for g in plan:
        if g.kind == "fused":
            flags = ~valid[g.name]
            if core is not None:
                flags[start:] = core[fault_key(g.name)]
            out[fault_key(g.name)] = flags
        else:
            out[fault_key(g.name)] = faults[g.name]
    return out


def in_range(plan, raw: dict, constants: dict, f) -> dict:
    """Per guarded input, per call, whether its reading is inside its guard's range (NaN is not), in `f`."""
    with np.errstate(invalid="ignore"):
        return {g.name: (raw[g.name] >= f(constants[g.low])) & (raw[g.name] <= f(constants[g.high])) for g in plan}


def guarded_predict(model: Model, inputs: dict, precision: str, limits: Limits, core_predict,
                    held: dict | None = None) -> dict:
    """Every block output, given raw inputs: guards, the model from the first all-valid call, limiter.
    `held`: the REAL outputs (limited values and K0) the block holds when it starts - zero for a new
    instance, the last values after a Reset."""
    held = held or {}
    f = np.float32 if precision == "f32" else np.float64
    constants = limits.values()
    plan = guards(model)
    rows = len(next(iter(inputs.values())))
    raw = {g.name: np.asarray(inputs[g.name], f) for g in plan}
    valid = in_range(plan, raw, constants, f)
    repeated = {g.name: stuck_readings(raw[g.name], valid[g.name], limits, f) for g in plan if g.kind != "range"}
    stuck = {name: flags for name, (flags, _) in repeated.items()}
    for g in plan:
        if g.kind == "fused":  # a stuck reading is no reading for the model's own filter
            valid[g.name] = valid[g.name] & ~stuck[g.name]
    all_valid = np.logical_and.reduce([valid[g.name] for g in plan])
    ready_row = int(np.argmax(all_valid)) if all_valid.any() else rows
    core_inputs, faults = {}, {}
    never = np.zeros(rows, bool)
    for g in plan:
        if g.kind == "fused":
            core_inputs[g.name] = raw[g.name]
        else:
            core_inputs[g.name], faults[g.name] = _hold(raw[g.name], valid[g.name], stuck.get(g.name, never), g,
                                                        ready_row, limits, f)
    running = {name: values[ready_row:] for name, values in core_inputs.items()}
    fused_valid = {g.name: valid[g.name][ready_row:] for g in plan if g.kind == "fused"}
    core = core_predict(model, running, precision, fused_valid) if ready_row < rows else None
    names = limited_outputs(core) if core is not None else real_outputs_of(model, core_predict, precision)
    flags = fault_flags(plan, valid, faults, core, ready_row)
    status = sensors_disagree(model, checked_values(plan, core_inputs, repeated), ready_row, limits, precision)
    core = held_while_faulty(core, names, {**flags, **status}, ready_row, limits, precision)
    probing = {}
    if model.probe is not None:
        core, probing = fused_core(model, core, inputs, ready_row, precision)
    out = {}
    limited = np.zeros(rows, bool)
    clamped = np.zeros(rows, bool)
    invalid = np.zeros(rows, bool)
    for name in names:
        y = f(held.get(name, 0))
        series = np.full(rows, y, f)
        if core is not None:
            kernels.limit(core[name], ready_row, np.array([y], f), series, limited, clamped, invalid, constants, f)
        out[name] = series
    for k, name in enumerate(axis_outputs(model, names), start=1):
        k0 = np.full(rows, held.get(k0_key(k), 0), f)
        k0[ready_row:] = out[name][ready_row:] * f(constants["k0_mm"])
        out[k0_key(k)] = k0
    out.update(flags)
    out.update(status)
    out.update(probing)
    out[READY] = np.arange(rows) >= ready_row
    out[LIMITED] = limited
    out[CLAMPED] = clamped
    out[INVALID] = invalid
    return out


def real_outputs_of(model: Model, core_predict, precision: str) -> list[str]:
    """Output names when the model never starts (no call had every input in range)."""
    probe = {s.name: np.full(1, 20.0, np.float32) for s in model.inputs}
    return limited_outputs(core_predict(model, probe, precision, {}))


def commissioned_predict(model: Model, inputs: dict, precision: str, limits: Limits, core_predict,
                         control: dict | None = None) -> dict:
    """Every block output with its Enable and Reset inputs per call (`control`, bool arrays; unwired
    ones keep their start values). A disabled call is skipped: the outputs hold and ENABLED is FALSE. A
    reset call starts the guards and the model afresh while the limited outputs hold their values."""
    rows = len(next(iter(inputs.values())))
    control = control or {}
    if unknown := set(control) - set(CONTROL_START):  # a block's input name here would be ignored silently
        raise ValueError(f"control keys {sorted(unknown)}: expected {sorted(CONTROL_START)}")
    enable = np.asarray(control.get(ENABLE, np.full(rows, CONTROL_START[ENABLE])), bool)
    reset = np.asarray(control.get(RESET, np.full(rows, CONTROL_START[RESET])), bool)
    if enable.all() and not reset[1:].any():
        out = guarded_predict(model, inputs, precision, limits, core_predict)
        out[ENABLED] = enable.copy()
        return out
    run = np.flatnonzero(enable)
    if not len(run):  # never enabled: every output keeps its start value; one call tells their types
        probe = guarded_predict(model, {k: np.asarray(v)[:1] for k, v in inputs.items()}, precision, limits, core_predict)
        return {**{name: np.zeros(rows, values.dtype) for name, values in probe.items()}, ENABLED: enable.copy()}
    starts = [0, *(int(k) for k in np.flatnonzero(reset[run]) if k > 0), len(run)]
    pieces: list[dict] = []
    held: dict = {}
    for a, b in zip(starts[:-1], starts[1:]):
        piece = guarded_predict(model, {k: np.asarray(v)[run[a:b]] for k, v in inputs.items()}, precision, limits,
                                core_predict, held)
        held = {name: values[-1] for name, values in piece.items() if values.dtype.kind == "f"}
        pieces.append(piece)
    shown = np.cumsum(enable) - 1  # per call, the enabled call whose outputs it shows (-1: none yet)
    out = {}
    for name in pieces[0]:
        ran = np.concatenate([p[name] for p in pieces])
        full = np.zeros(rows, ran.dtype)
        full[shown >= 0] = ran[shown[shown >= 0]]
        out[name] = full
    out[ENABLED] = enable.copy()
    return out
