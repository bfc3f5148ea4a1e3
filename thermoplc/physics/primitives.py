"""The pieces the lumped-mass simulation (physics/simulation.py) is built from: the recording by
role, the fitted parameters, the first-order lag, the speed heat, the least squares.
They know no named effect, so the effect records (physics/effects/) can name their types."""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from thermoplc.base import compiled


def minimize(*args, **kwargs):  # scipy on first use: verify never fits, and importing it costs ~1 s
    """scipy.optimize.minimize itself (same arguments, same result), imported on the first call."""
    from scipy.optimize import minimize as function
    return function(*args, **kwargs)

def minimize_scalar(*args, **kwargs):  # scipy on first use: verify never fits, and importing it costs ~1 s
    """scipy.optimize.minimize_scalar itself (same arguments, same result), imported on the first call."""
    from scipy.optimize import minimize_scalar as function
    return function(*args, **kwargs)

def lfilter(*args, **kwargs):  # scipy on first use: verify never fits, and importing it costs ~1 s
    """scipy.signal.lfilter itself (same arguments, same result), imported on the first call."""
    from scipy.signal import lfilter as function
    return function(*args, **kwargs)

def savgol_filter(*args, **kwargs):  # scipy on first use: verify never fits, and importing it costs ~1 s
    """scipy.signal.savgol_filter itself (same arguments, same result), imported on the first call."""
    from scipy.signal import savgol_filter as function
    return function(*args, **kwargs)


HOUR = 3600.0
SPEED_GAP_SHARE = 0.005
MAX_SPEED_LEVELS = 48
GRAM_CONDITION_LIMIT = 1e8  # above this the normal equations lose digits the fit needs


@dataclass(frozen=True)
class Series:
    """One recording by role. Rows are equally spaced by `dt`."""
    dt: float
    t: np.ndarray
    n: np.ndarray
    te: np.ndarray
    temps: np.ndarray  # (rows, sensors)
    names: tuple[str, ...]
    target: np.ndarray
    feed: np.ndarray | None = None

    @property
    def rows(self) -> int:
        return len(self.t)

    def head(self, rows: int) -> "Series":
        return replace(self, t=self.t[:rows], n=self.n[:rows], te=self.te[:rows], temps=self.temps[:rows],
                       target=self.target[:rows], feed=None if self.feed is None else self.feed[:rows])


@dataclass(frozen=True)
class Shared:
    """Parameters every sensor shares: what the machine does, not where a sensor sits."""
    stopped_rpm: float
    gear_rpm: float | None = None
    gear_tau_s: float = 0.0  # the lag the heat above the gear threshold enters through (0: none)
    exponent: float | None = None
    reference_rpm: float = 1.0
    table_rpm: tuple[float, ...] = ()  # nodes of the n^p table
    relay: tuple[int, float, float] | None = None  # (sensor, on at degC, off at degC)
    cool_tau_s: float = 0.0  # the lag the coolant's cooling reaches the sensors through (0: at once)


@dataclass(frozen=True)
class SensorParams:
    tau_s: float
    gain: float
    stop_factor: float = 1.0
    load_K: float = 0.0  # standstill heat load: how far above the air the sensor settles with the spindle still
    gear_gain: float = 0.0
    cooling: float = 0.0
    offset_K: float = 0.0
    drift_K_per_s: float = 0.0
    filter_gain: float = 0.0  # steady-state Kalman gain on the reading (0: open loop, the simulation alone)


@dataclass(frozen=True)
class DisplacementParams:
    tau_struct_s: float | None  # None: the displacement follows the temperatures without a structure lag
    beta0: float
    beta: tuple[float, ...]
    gamma: tuple[float, ...]
    tau_slow_s: float | None = None
    delta: tuple[float, ...] = ()
    tau_ambient_s: float | None = None
    alpha: float = 0.0
    tau_feed_s: float | None = None
    phi: float = 0.0
    # the ridge weight of a map identified by forward validation (physics/identify.py), held when effects
    # extend it; None: plain least squares (the open-loop simulation diagnose fitted before)
    ridge_weight: float | None = None
    # the structure lag forward validation chose: a refit for the diagnosis stays within a grid step of it
    # (physics/identified_effects.py), however many times the map is refitted
    tau_struct_chosen_s: float | None = None


def pole(tau_s: float, dt: float) -> float:
    """The share a = exp(-dt/tau) a first-order lag keeps of its last value per row of `dt` s (tau in s too)."""
    return float(np.exp(-dt / tau_s))


def lag(x: np.ndarray, a, y0: float) -> np.ndarray:
    """y[j] = a[j] y[j-1] + (1 - a[j]) x[j], y[-1] = y0; `a` a number or one value per row."""
    if np.ndim(a) == 0:
        return lfilter([1.0 - a], [1.0, -a], x, zi=[a * y0])[0]
    out = np.empty(len(x))
    change = np.flatnonzero(np.diff(a)) + 1
    y = y0
    for start, stop in zip(np.r_[0, change], np.r_[change, len(x)]):
        if stop > start:
            p = a[start]
            out[start:stop] = lfilter([1.0 - p], [1.0, -p], x[start:stop], zi=[p * y])[0]
            y = out[stop - 1]
    return out


@compiled.jit
def _lag_columns(x, a, y0):
    rows, m = x.shape
    out = np.empty((rows, m))
    y = y0.copy()
    b = 1.0 - a
    for j in range(rows):
        for i in range(m):
            y[i] = b[i] * x[j, i] + a[i] * y[i]
            out[j, i] = y[i]
    return out


def lag_columns(x: np.ndarray, a: float, y0: np.ndarray) -> np.ndarray:
    """`lag` of every column of `x` (rows, m) by one pole, column i from y0[i]; for finite values the
    same bits as `lag` column by column (one product each, then one sum; lfilter turns an infinite
    input into NaN one row later, this keeps it infinite), and several times faster, since the
    displacement fit lags every sensor thousands of times and the columns run side by side."""
    if compiled.numba is None:
        return np.column_stack([lag(x[:, i], a, y0[i]) for i in range(x.shape[1])])
    return _lag_columns(np.ascontiguousarray(x, dtype=float), np.full(x.shape[1], float(a)),
                        np.asarray(y0, dtype=float))


def stopped(series: Series, shared: Shared) -> np.ndarray:
    """Per row, True where the spindle counts as standing: speed at or below `shared.stopped_rpm`."""
    return series.n <= shared.stopped_rpm


def speed_table(shared: Shared) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nodes, values and slopes of the n^p heat table (the block interpolates the same table)."""
    nodes = np.asarray(shared.table_rpm)
    values = shared.reference_rpm * (nodes / shared.reference_rpm) ** shared.exponent
    slopes = np.diff(values) / np.diff(nodes)
    return nodes[:-1], values[:-1], slopes


def speed_heat(n: np.ndarray, shared: Shared) -> np.ndarray:
    """The speed heat s(n) per row: n itself, or with an exponent fitted the n^p table interpolated at n as
    the block interpolates it (extended linearly beyond its ends)."""
    if shared.exponent is None:
        return n
    nodes, values, slopes = speed_table(shared)
    index = np.clip(np.searchsorted(nodes, n, side="right") - 1, 0, len(nodes) - 1)
    return values[index] + (n - nodes[index]) * slopes[index]


def speed_levels(n: np.ndarray, shared: Shared) -> np.ndarray:
    """The highest speed of each group of running speeds (groups split where sorted speeds jump by
    more than `SPEED_GAP_SHARE` of the top speed): a gear threshold at one of these separates the
    groups the data can tell apart. Quantiles where the speeds form no groups (a continuous sweep)."""
    running = np.sort(n[n > shared.stopped_rpm])
    if len(running) == 0:
        return running
    jumps = np.flatnonzero(np.diff(running) > SPEED_GAP_SHARE * running[-1])
    levels = np.r_[running[jumps], running[-1]]
    if len(levels) > MAX_SPEED_LEVELS:
        levels = np.unique(np.quantile(running, np.linspace(0.02, 0.98, MAX_SPEED_LEVELS)))
    return levels


def least_squares(y: np.ndarray, columns: list[np.ndarray]):
    """Least squares by the normal equations of the column-scaled design (the searches call this
    tens of thousands of times); an SVD where the scaled Gram matrix is ill-conditioned."""
    design = np.column_stack(columns)
    scale = np.sqrt(np.einsum("ij,ij->j", design, design))
    scale[scale == 0.0] = 1.0
    scaled = design / scale
    gram = scaled.T @ scaled
    if np.linalg.cond(gram) < GRAM_CONDITION_LIMIT:
        coef = np.linalg.solve(gram, scaled.T @ y) / scale
    else:
        coef = np.linalg.lstsq(design, y, rcond=None)[0]
    residual = y - design @ coef
    return coef, float(residual @ residual)



def first_temperatures(series: Series, sensors) -> np.ndarray:
    """Physical temperature at each sensor before the first row: its first reading less the offset."""
    return np.array([series.temps[0, i] - p.offset_K for i, p in enumerate(sensors)])



def stopped_threshold(n: np.ndarray) -> float:
    """Speeds at or below 1 % of the highest speed count as standing (sensor noise at standstill)."""
    return 0.01 * max(float(np.max(np.abs(n))), 1.0)

