"""Which columns may stand for temperatures in a fit or a sensor selection.

A model fitted on the answer in disguise (the target under another name, a copy of it up to scale
and offset, a displacement column, a feed rate behind a temperature guard) reports a tiny error
and compensates nothing on the machine; these checks refuse such columns with the reason. A
temperature that predicts the target well is not refused however well it does: a well-placed
sensor is the best case of the physics; it reaches the target through heat flow and has noise of
its own, where a copy leaves only the noise it shares with the target.
"""
from __future__ import annotations

import re

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.models.safety import Limits
from thermoplc.recordings.table import Table

# T_env, T1, t1_C, Temp_spindle, spindle_temperature, bed_degC: the names recorders give temperatures
TEMPERATURE_NAME = re.compile(r"^t(_|\d|$)|temp|(^|_)(deg_?c|c|celsius)$", re.IGNORECASE)
UNIT_SUFFIX = re.compile(r"_(um|µm|mm|nm|m|urad|mrad|rad|arcsec)$", re.IGNORECASE)
COPY_NOISE_MULTIPLE = 3.0  # a copy's misfit stays within a few noise sigmas of the two columns
COPY_MIN_R2 = 0.9  # and it explains the target: a column of mostly noise maps to anything "within its noise"
SHARED_NOISE_MIN = 0.2  # a copy with 3x the target's noise of its own still correlates 0.3 sample to sample
SHARED_NOISE_SIGMAS = 5.0
WHITE_WINDOW = 30  # calls averaged to see the slow part of a misfit
WHITE_STANDARD_ERRORS = 3.0  # a white misfit's average over the window stays within this many standard errors
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
    copy = _copy_of(np.asarray(values, np.float64), np.asarray(target_values, np.float64))
    if copy is not None:
        misfit, noise = copy
        return (f"is a copy of the target {target!r} (an affine map of it leaves {misfit:.3g} RMS, within "
                f"{COPY_NOISE_MULTIPLE:g}x the measurement noise {noise:.3g} of the two): it is the answer, "
                "not a cause")
    return None


def noise_sigma(x: np.ndarray) -> float:
    """Measurement noise of a sampled signal: the robust spread of its second differences (a smooth
    signal's slope and curvature barely reach them, white noise does with variance 6 sigma^2)."""
    x = x[np.isfinite(x)]
    if len(x) < 5:
        return 0.0
    second = np.diff(x, 2)
    return float(1.4826 * np.median(np.abs(second - np.median(second))) / np.sqrt(6.0))


def _affine_misfit(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """RMS of y less its best affine map of x, that map's slope and the misfit's slow part in standard
    errors (finite, non-constant x and y)."""
    design = np.column_stack([np.ones_like(x), x - x.mean()])
    coef = np.linalg.lstsq(design, y, rcond=None)[0]
    misfit = y - design @ coef
    return float(np.sqrt(np.mean(misfit ** 2))), float(coef[1]), _slow_part(misfit)


def _shares_noise(x: np.ndarray, y: np.ndarray) -> bool:
    """Whether the column carries the target's own sample-to-sample noise: a copy does, a
    temperature sensor has noise of its own. Rank correlation of the second differences, above
    `SHARED_NOISE_MIN` and above chance (`SHARED_NOISE_SIGMAS` standard errors)."""
    dx, dy = np.diff(x, 2), np.diff(y, 2)
    if np.ptp(dx) == 0 or np.ptp(dy) == 0:
        return False
    rank = lambda v: np.argsort(np.argsort(v)).astype(float)
    r = abs(float(np.corrcoef(rank(dx), rank(dy))[0, 1]))
    return r >= max(SHARED_NOISE_MIN, SHARED_NOISE_SIGMAS / np.sqrt(len(dx)))


def _slow_part(misfit: np.ndarray) -> float:
    """The misfit's RMS after averaging over `WHITE_WINDOW` calls, in standard errors of white noise
    of its own sample-to-sample sigma: about 1 for noise, large where heat flow shaped it."""
    window = min(WHITE_WINDOW, max(len(misfit) // 10, 1))
    sigma = noise_sigma(misfit)
    slow = np.convolve(misfit, np.full(window, 1.0 / window), mode="valid")
    rms = float(np.sqrt(np.mean(slow ** 2)))
    return rms / (sigma / np.sqrt(window)) if sigma > 0 else (0.0 if rms == 0 else np.inf)


def _copy_of(x: np.ndarray, y: np.ndarray) -> tuple[float, float] | None:
    """(misfit, noise) if the column is the target up to an affine map at the same call, within the
    noise of the two, else None. A displacement that follows a temperature some time later is what
    a structure does, so no shift in time is searched. A temperature that drives the target, however
    well, reaches it through heat flow (and beside other heat paths): its misfit is slow and stands
    above the sample-to-sample noise. A copy's misfit is the noise itself: small and white."""
    finite = np.isfinite(x) & np.isfinite(y)
    x, y = x[finite], y[finite]
    if len(x) < 5 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return None
    misfit, slope, slow = _affine_misfit(x, y)
    noise = float(np.hypot(noise_sigma(y), slope * noise_sigma(x)))
    exact = misfit <= 1e-9 * float(np.ptp(y))
    explains = misfit ** 2 <= (1.0 - COPY_MIN_R2) * float(np.var(y))
    if exact or (explains and misfit <= COPY_NOISE_MULTIPLE * noise and slow <= WHITE_STANDARD_ERRORS
                 and _shares_noise(x, y)):
        return misfit, noise
    return None


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
