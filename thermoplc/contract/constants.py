"""Which value each declared constant and read-only table of a block must hold, from the model.

The naming rule, written once: a model coefficient X is the constant `c_X`; a table `tab_Stem`
(or `tab_Stem_i`) holds the coefficients `stem_k` (or `stem_i_k`) in order, k from 0 when the
model has a `stem_0` and from 1 otherwise; each value of the safety logic (`Limits.values()`) is
the constant `LIMIT_NAMES` gives it. What is neither is structure the model's settings fix (a ring buffer's
length, the interval counts of a configuration index) or a plain 0/1 the block computes with.
"""
from __future__ import annotations

import re

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.models.kinds import kind_of
from thermoplc.models.model import Model
from thermoplc.base.binary32 import FADE_FLOOR, round_f32
from thermoplc.models.plausibility import quiet_K, swing_factors, swing_quiet_K
from thermoplc.models.probing import COUNT_MAX, HELD_MAX, REJOIN, STUCK_COUNT, STUCK_SHARE
from thermoplc.models.safety import Limits, axis_outputs, guards

CONSTANT_PREFIX = "c_"
TABLE_PREFIX = "tab_"
LIMIT_NAMES = {"temp_min": "c_TempMin", "temp_max": "c_TempMax", "speed_min": "c_SpeedMin", "speed_max": "c_SpeedMax",
               "other_min": "c_OtherMin", "other_max": "c_OtherMax", "jump_max": "c_JumpMax",
               "settle_calls": "c_SettleCalls", "stuck_calls": "c_StuckCalls", "one_call": "c_OneCall",
               "step_max": "c_StepMax",
               "step_min": "c_StepMin", "out_max": "c_OutMax", "out_min": "c_OutMin", "k0_mm": "c_K0_mm",
               "real_max": "c_RealMax", "fault_move": "c_FaultMove",
               "fault_fade": "c_FaultFade", "fault_floor": "c_FaultFloor"}  # a value of the safety logic -> its constant
NEEDED_LIMITS = ("step_max", "out_max")  # every block limits its outputs: without them it is not one of ours
_TABLE = re.compile(r"tab_([A-Za-z][A-Za-z0-9]*)(?:_(\d+))?\Z", re.IGNORECASE)  # ST names ignore case


def constant_name(coefficient: str) -> str:
    """The block constant that holds model coefficient `coefficient`: its name after `c_`, case kept."""
    return CONSTANT_PREFIX + coefficient


def limit_name(key: str) -> str:
    """The block constant that holds safety value `key` (a key of Limits.values()); KeyError for others."""
    return LIMIT_NAMES[key]


def limit_constants(limits: Limits) -> dict:
    """The safety logic's constants as the block declares them (name -> binary32 value or INT)."""
    return {limit_name(key): value for key, value in limits.values().items()}


def limits_of_block(declared: dict, source: str) -> Limits:
    """The limits a block was generated with, read back from its constants (name -> value)."""
    upper = {name.upper(): value for name, value in declared.items()}
    missing = [limit_name(key) for key in NEEDED_LIMITS if limit_name(key).upper() not in upper]
    if missing:
        raise UserError(f"{source}: the block has no safety constants ({', '.join(missing)}); "
                        f"regenerate it with this version of thermoplc")
    # a limit the block does not use (no speed input, say) keeps its default: it cannot change an output
    return Limits.from_values({key: upper[name.upper()] for key, name in LIMIT_NAMES.items() if name.upper() in upper})


def table_coefficients(model: Model, table: str) -> tuple[str, ...] | None:
    """The coefficient names table `table` holds, in order, or None when it is not a table of the model's."""
    match = _TABLE.match(table)
    if not match:
        return None
    stem, sensor = match.group(1), match.group(2)
    prefix = (stem + (f"_{sensor}" if sensor else "") + "_").lower()
    known = {name.lower(): name for name in model.coefficients}
    first = 0 if f"{prefix}0" in known else 1
    names = []
    while f"{prefix}{first + len(names)}" in known:
        names.append(known[f"{prefix}{first + len(names)}"])
    return tuple(names) or None


def required(model: Model) -> set[str]:
    """The constants every block of this model declares whatever its coefficients: the structure,
    each guard's range, the jump and settle rule of a held temperature, every temperature's stuck rule, the output limiter and the
    K0 factor of an output in um. A block without one of them computes with something else."""
    keys = {"step_max", "step_min", "out_max", "out_min", "real_max", "fault_move", "fault_fade", "fault_floor"}
    for guard in guards(model):
        keys |= {guard.low, guard.high}
        if guard.kind == "temperature":
            keys |= {"jump_max", "one_call", "settle_calls"}
        if guard.kind in ("temperature", "fused"):
            keys |= {"one_call", "stuck_calls"}
    if axis_outputs(model, [model.target.name, *(t["name"] for t in model.settings.get("targets", ()))]):
        keys.add("k0_mm")
    return set(structure(model)) | {limit_name(key) for key in keys}  # structure: the check's constants too


def structure_name(key: str) -> str:
    """The block constant of a structure value its kind's record keys by what it is: `len` is `c_Len`,
    `lag_2` is `c_Lag_2`, `k_1` is `c_K_1`."""
    return CONSTANT_PREFIX + "_".join(part if part.isdigit() else part.capitalize() for part in key.split("_"))


def structure(model: Model) -> dict:
    """Constants the settings fix (INT as int, REAL as binary32 float): what a kind's block counts with, as
    its record says (Kind.structure), named by `structure_name`."""
    out: dict = {"c_Zero": 0.0}
    out.update({structure_name(key): value for key, value in kind_of(model.kind).structure(model).items()})
    if model.probe is not None:
        out.update(probe_constants(model))
    if model.start is not None:
        out.update(start_constants(model))
    if model.plausibility is not None:
        out.update(plausibility_constants(model))
    return out


SWING_KEEP, SWING_ALPHA = "c_PlausKeep", "c_PlausAlpha"  # the slow means' factors per call (swing_factors)


def plausibility_names(model: Model) -> dict:
    """Per checked input: (intercept constant, {other input: slope constant}, gate constant, quiet constant, swing
    gate constant, swing quiet constant), each named by the inputs' positions among the block inputs (c_PlausA_1,
    c_PlausB_1_2, c_PlausGate_1, c_PlausQuiet_1, c_PlausSwing_1, c_PlausSwingQuiet_1)."""
    index = {g.name: g.index for g in guards(model)}
    return {r.sensor: (f"c_PlausA_{index[r.sensor]}",
                       {name: f"c_PlausB_{index[r.sensor]}_{index[name]}" for name, _ in r.slopes},
                       f"c_PlausGate_{index[r.sensor]}", f"c_PlausQuiet_{index[r.sensor]}",
                       f"c_PlausSwing_{index[r.sensor]}", f"c_PlausSwingQuiet_{index[r.sensor]}")
            for r in model.plausibility.relations}


def plausibility_constants(model: Model) -> dict:
    """The cross-sensor check's constants as the block declares them (name -> binary32 value)."""
    names, out = plausibility_names(model), {}
    for r in model.plausibility.relations:
        intercept, slopes, gate, quiet, swing, swing_quiet = names[r.sensor]
        out[intercept] = r.intercept[1]
        out.update({slopes[name]: slope[1] for name, slope in r.slopes})
        if r.gate_K is not None:
            out[gate] = r.gate_K[1]
            out[quiet] = quiet_K(r)
        if model.plausibility.swings:
            out[swing] = r.swing_K[1]
            out[swing_quiet] = swing_quiet_K(r)
    if model.plausibility.swings:
        out[SWING_KEEP], out[SWING_ALPHA] = swing_factors(model.sample_period_s)
    return out


START_NAMES = {"drift_um": "c_StartDrift", "decay": "c_StartDecay"}  # a constant of the known start -> its name


def start_constants(model: Model) -> dict:
    """The known start's constants as the block declares them (name -> binary32 value)."""
    return {**{START_NAMES[key]: value for key, value in model.start.values().items()},
            "c_StartFloor": round_f32(FADE_FLOOR)}


PROBE_NAMES = {"gain": "c_ProbeGain", "gate_um": "c_ProbeGate", "limit_um": "c_ProbeLimit",
               "offset_max_um": "c_ProbeOffsetMax", "rate_gain": "c_ProbeRateGain", "rate_max_um": "c_ProbeRateMax",
               "decay": "c_ProbeDecay", "min_calls": "c_ProbeMinCalls"}  # a constant of the probe fusion -> the block constant that holds it
PROBE_NEGATED = {"offset_max_um": "c_ProbeOffsetMin", "rate_max_um": "c_ProbeRateMin"}  # the lower clamps


def probe_constants(model: Model) -> dict:
    """The probe fusion's constants as the block declares them (name -> binary32 value or INT)."""
    values = model.probe.values()
    out = {PROBE_NAMES[key]: int(value) if key == "min_calls" else value for key, value in values.items()}
    out.update({PROBE_NEGATED[key]: -value for key, value in values.items() if key in PROBE_NEGATED})
    out.update({"c_ProbeCountMax": COUNT_MAX, "c_ProbeOne": 1, "c_ProbeRejoin": REJOIN,
                "c_ProbeStuckCount": STUCK_COUNT, "c_ProbeHeldMax": HELD_MAX,
                "c_ProbeStuckMove": float(np.float32(values["gate_um"]) * np.float32(STUCK_SHARE))})
    return out


def expected(model: Model, limits: Limits, declared: list[str]) -> tuple[dict, list[str], list[str]]:
    """For the names a block declares as constants or initialised tables: the values the model says
    each must hold (a tuple, one per entry); the declared names the model has no value for; and the
    model's coefficients the block holds nowhere."""
    wanted, unknown, placed = {}, [], set()
    fixed = {k.upper(): v for k, v in {**limit_constants(limits), **structure(model)}.items()}
    coefficients = {constant_name(k).upper(): k for k in model.coefficients}
    for name in declared:
        key = name.upper()
        table = table_coefficients(model, name) if key.startswith(TABLE_PREFIX.upper()) else None
        if key in coefficients:
            wanted[name] = (model.coef(coefficients[key]),)
            placed.add(coefficients[key])
        elif table:
            wanted[name] = tuple(model.coef(k) for k in table)
            placed.update(table)
        elif key in fixed:
            wanted[name] = (fixed[key],)
        else:
            unknown.append(name)
    return wanted, unknown, [k for k in model.coefficients if k not in placed]
