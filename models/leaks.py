"""Which columns may stand for temperatures in a fit or a sensor selection.

A model fitted on the answer in disguise (the target under another name, a column that predicts
it almost perfectly on its own, a feed rate behind a temperature guard) reports a tiny error and
compensates nothing on the machine; these checks refuse such columns with the reason.
"""
from __future__ import annotations

import re

import numpy as np

from thermoplc.errors import UserError
from thermoplc.models.safety import Limits
from thermoplc.models.table import Table

# T_env, T1, t1_C, Temp_spindle, spindle_temperature, bed_degC: the names recorders give temperatures
TEMPERATURE_NAME = re.compile(r"^t(_|\d|$)|temp|(^|_)(deg_?c|c|celsius)$", re.IGNORECASE)
UNIT_SUFFIX = re.compile(r"_(um|µm|mm|nm|m|urad|mrad|rad|arcsec)$", re.IGNORECASE)
PERFECT_R2 = 0.995  # one column alone explaining 99.5 % of the target's variance is the target, not a cause
TEMPERATURE_RULE = ("names starting with T followed by '_', a digit or nothing, or containing 'temp', or ending "
                    "in _C/_degC, whose values all lie in {low:g}..{high:g} degC")


def looks_like_temperature(name: str) -> bool:
    return bool(TEMPERATURE_NAME.search(name))


def temperature_columns(columns: dict, excluded: tuple[str, ...], limits: Limits = Limits()) -> tuple[str, ...]:
    """Columns recognised as temperatures: a temperature name and every finite value in the guard range."""
    chosen = []
    for name, values in columns.items():
        if name in excluded or not looks_like_temperature(name):
            continue
        values = np.asarray(values, np.float64)
        if values.size and np.all((values >= limits.temp_min_C) & (values <= limits.temp_max_C)):
            chosen.append(name)
    return tuple(chosen)


def _stem(name: str) -> str:
    return UNIT_SUFFIX.sub("", name).lower()


def leak_reason(name: str, values: np.ndarray, target: str, target_values: np.ndarray) -> str | None:
    """Why `name` must not stand for a temperature in a model of `target`, or None."""
    if name == target:
        return "is the target"
    stem, target_stem = _stem(name), _stem(target)
    if stem == target_stem or stem.startswith(target_stem + "_") or target_stem.startswith(stem + "_"):
        return f"is named like the target {target!r}"
    unit, target_unit = UNIT_SUFFIX.search(name), UNIT_SUFFIX.search(target)
    if unit and target_unit and unit.group(1).lower() == target_unit.group(1).lower():
        return f"is a displacement column (unit _{unit.group(1)}) like the target {target!r}"
    r2, how = _best_fit(np.asarray(values, np.float64), np.asarray(target_values, np.float64))
    if r2 >= PERFECT_R2:
        return (f"predicts the target {target!r} almost perfectly on its own ({how}: R^2 {r2:.5f}, it leaves "
                f"{np.sqrt(max(1.0 - r2, 0.0)):.1%} of the target's spread): it is the answer, not a cause")
    return None


LAGS = (0, 1, 2, 3, 5, 10, 20, 30, 60, 120, 360)  # calls: a copy of the target recorded earlier or later


def _r2(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """R^2 of a straight line and of a parabola through (x, y)."""
    finite = np.isfinite(x) & np.isfinite(y)
    x, y = x[finite], y[finite]
    if len(x) < 4 or np.std(x) == 0 or np.std(y) == 0:
        return 0.0, 0.0
    line = float(np.corrcoef(x, y)[0, 1]) ** 2
    z = (x - x.mean()) / x.std()
    design = np.column_stack([np.ones_like(z), z, z * z])
    coef = np.linalg.lstsq(design, y, rcond=None)[0]
    parabola = 1.0 - float(np.mean((y - design @ coef) ** 2) / np.var(y))
    return line, parabola


def _best_fit(x: np.ndarray, y: np.ndarray) -> tuple[float, str]:
    """The best R^2 of the target on the column alone: a line or a parabola, shifted by up to 360 calls."""
    best, how = 0.0, ""
    for lag in LAGS:
        if lag >= len(x) - 3:
            break
        pairs = [(x, y, "same call")] if lag == 0 else [(x[:-lag], y[lag:], f"the column leading by {lag} calls"),
                                                         (x[lag:], y[:-lag], f"the column lagging by {lag} calls")]
        for a, b, when in pairs:
            line, parabola = _r2(a, b)
            for r2, shape in ((line, "a straight line"), (parabola, "a parabola")):
                if r2 > best + 1e-9:  # the simpler shape and the smaller shift when they explain as much
                    best, how = r2, f"{shape}, {when}"
    return best, how


def refuse_leaks(columns: dict, target: str, target_values: np.ndarray, where: str, option: str) -> None:
    """Refuse, naming the first offender, a column that is the target in disguise."""
    for name, values in columns.items():
        reason = leak_reason(name, values, target, target_values)
        if reason:
            raise UserError(f"{where}: {option} column {name!r} {reason}; a thermal model must explain the target "
                            f"from temperatures")


def refuse_non_temperatures(table: Table, names, option: str, limits: Limits = Limits()) -> None:
    """Refuse a column given as a temperature whose values leave the plausible temperature range."""
    for name in names:
        values = table.column(name)
        outside = ~((values >= limits.temp_min_C) & (values <= limits.temp_max_C))
        if outside.any():
            count = int(outside.sum())
            table.refuse_cell(name, outside, f"a temperature ({option}; {count} row{'s' if count != 1 else ''} outside)",
                              f"{limits.temp_min_C:g}..{limits.temp_max_C:g} degC: {option} takes temperature "
                              f"columns (repair or cut faulty readings)")
