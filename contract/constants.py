"""Which value each declared constant and read-only table of a block must hold, from the model.

The naming rule, written once: a model coefficient X is the constant `c_X`; a table `tab_Stem`
(or `tab_Stem_i`) holds the coefficients `stem_k` (or `stem_i_k`) in order, k from 0 when the
model has a `stem_0` and from 1 otherwise; the safety limits are the constants of
`Limits.constants()`. What is neither is structure the model's settings fix (a ring buffer's
length, the interval counts of a configuration index) or a plain 0/1 the block computes with.
"""
from __future__ import annotations

import re

from thermoplc.base.binary32 import round_f32
from thermoplc.models.modelfile import Model
from thermoplc.models.safety import Limits, axis_outputs, guards

CONSTANT_PREFIX = "c_"
TABLE_PREFIX = "tab_"
_TABLE = re.compile(r"tab_([A-Za-z][A-Za-z0-9]*)(?:_(\d+))?\Z", re.IGNORECASE)  # ST names ignore case


def constant_name(coefficient: str) -> str:
    return CONSTANT_PREFIX + coefficient


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
    each guard's range, the jump and settle rule of a held temperature, the output limiter and the
    K0 factor of an output in um. A block without one of them computes with something else."""
    names = set(structure(model)) | {"c_StepMax", "c_StepMin", "c_OutMax", "c_OutMin", "c_RealMax"}
    for guard in guards(model):
        names |= {guard.low, guard.high}
        if guard.kind == "temperature":
            names |= {"c_JumpMax", "c_OneCall", "c_SettleCalls"}
    if axis_outputs(model, [model.target.name, *(t["name"] for t in model.settings.get("targets", ()))]):
        names.add("c_K0_mm")
    return names


def structure(model: Model) -> dict:
    """Constants the settings fix (INT as int, REAL as binary32 float): what a kind's block counts with."""
    s = model.settings
    out: dict = {"c_Zero": 0.0}
    if model.kind == "dlag":
        step, lags = s["lag_step_samples"], s["lags"]
        out.update({"c_One": 1, "c_Len": lags * step + 1, "c_Last": lags * step})
        out.update({f"c_Lag_{lag}": lag * step for lag in range(lags + 1)})
    elif model.kind == "bayes":
        counts = s["intervals"]
        out.update({f"c_K_{i}": counts[i - 1] for i in range(1, len(counts))})
        if s.get("time_parent"):
            out["c_Dt"] = round_f32(model.sample_period_s)
    elif model.kind == "piecewise":
        out["c_One"] = 1.0
    return out


def expected(model: Model, limits: Limits, declared: list[str]) -> tuple[dict, list[str], list[str]]:
    """For the names a block declares as constants or initialised tables: the values the model says
    each must hold (a tuple, one per entry); the declared names the model has no value for; and the
    model's coefficients the block holds nowhere."""
    wanted, unknown, placed = {}, [], set()
    fixed = {k.upper(): v for k, v in {**limits.constants(), **structure(model)}.items()}
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
