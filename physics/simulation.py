"""The lumped-mass simulation of paper 000 (eq. 4) with named effects, in float64 for fitting.

Per temperature sensor i the simulation runs open loop from speed and ambient alone:
    T_i[j] = a_i T_i[j-1] + (1-a_i) (Te[j] + q_i[j])                       (starts at T_i[0] - offset_i)
    q_i = h_i + g_i s(n) + [gear] g2_i n [n > threshold] + [coolant] k_i cool
with h_i the heat load of a machine that is powered with the spindle still (drives, hydraulics, a
chiller: a real machine is rarely at the air's temperature at standstill), a_i = exp(-dt/tau_i)
(tau_i times a factor while the spindle stands, stop_convection) and
s(n) = n, or n^p through a node table (nonlinear_speed_heat). The sensor reads T_i plus
offset_i and drift_i * t. The displacement is regressed on the simulated temperatures, the
ambient-driven part included (paper 000 eq. 10/16), and on a structure that lags them:
    E = beta0 + sum_i beta_i (T_i - T0_i) [+ gamma_i (L_i - T0_i)] [+ delta_i (M_i - T0_i)]
        [+ alpha (lag_a(Te) - Te[0])] [+ phi lag_f(feed)]
with L_i = lag_struct(T_i) (the structure lag, on by default), M_i = lag_slow(L_i or T_i)
(slow_structure). Nonlinear parameters (time constants, thresholds, exponent) are searched; the
gains follow by least squares (variable projection), so every fit is deterministic.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from thermoplc.models import kernels
from thermoplc.physics.effects import definition_of, registry, with_part
from thermoplc.physics.effects.definition import DisplacementTerm


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


TABLE_SEGMENTS = 16
RELAY_ROUNDS = 4
RELAY_GRID_STEP_K = 0.05
RELAY_GRID_LEVELS = 80
RELAY_SMOOTHING_ROWS = 9
RELAY_LOOKAHEAD_S = 7200.0
CLOSED_LOOP_ROUNDS = 2  # relay state from the simulation, sensors refitted with it
HOUR = 3600.0
SPEED_GAP_SHARE = 0.005
MAX_SPEED_LEVELS = 48
GRID_POINTS = 13  # per time constant searched anew in the displacement
POLISHED_STARTS = 4
EXPONENT_RANGE = (0.2, 3.5)
GRAM_CONDITION_LIMIT = 1e8  # above this the normal equations lose digits the fit needs
SEARCH_ROUNDS = 2  # shared parameter by grid with the time constants held, then the time constants


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
    exponent: float | None = None
    reference_rpm: float = 1.0
    table_rpm: tuple[float, ...] = ()  # nodes of the n^p table
    relay: tuple[int, float, float] | None = None  # (sensor, on at degC, off at degC)


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


@dataclass(frozen=True)
class Simulation:
    effects: tuple[tuple[str, int | None], ...]  # (name, sensor index for per-sensor effects), in order added
    shared: Shared
    sensors: tuple[SensorParams, ...]
    displacement: DisplacementParams

    def has(self, name: str) -> bool:
        return any(e == name for e, _ in self.effects)

    @property
    def filtered(self) -> bool:
        """True for an identified model: its temperatures follow the readings through the filter gains."""
        return any(p.filter_gain for p in self.sensors)

    def sensor_of(self, name: str) -> int | None:
        return next((s for e, s in self.effects if e == name), None)

    def parameter_count(self) -> int:
        """Fitted parameters: per sensor a time constant, a gain and a standstill load; the
        displacement's offset and a weight per sensor; with the structure lag its time constant and
        a second weight per sensor; and what each effect adds (its record says how many)."""
        k = len(self.sensors)
        structure = self.displacement.tau_struct_s is not None
        count = 3 * k + 1 + k + (1 + k) * structure + k * self.filtered
        return count + sum(definition_of(name).added_parameters(k) for name in {e for e, _ in self.effects})


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


@kernels.jit
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
    if kernels.numba is None:
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


def relay(temperature: np.ndarray, on: float, off: float) -> np.ndarray:
    """Coolant state used at each row: switched by the temperatures of the rows before (hysteresis)."""
    above, below = temperature > on, temperature < off
    events = np.where(above | below, np.arange(len(temperature)), -1)
    last = np.maximum.accumulate(events)
    state = np.where(last >= 0, above[np.maximum(last, 0)], False)
    return np.r_[False, state[:-1]].astype(float)


def closed_loop_cooling(series: Series, shared: Shared, sensors, effects) -> np.ndarray:
    """Coolant state per row (1.0 while cooling), switched by the *simulated* temperature of the relay
    sensor: the coolant's controller reacts to the true temperature, which the simulation estimates
    without the sensor noise that would trip a relay early. Between switches the sensor is a
    linear lag, so the state is found switch by switch over windows of `RELAY_LOOKAHEAD_S`."""
    index, on, off = shared.relay
    p = sensors[index]
    a = np.broadcast_to(_poles(series, shared, p), (series.rows,))
    drive = series.te + sum(getattr(p, name) * x for name, x in _heat_inputs(series, replace(shared, relay=None), effects))
    if p.filter_gain:
        return _filtered_relay(series.temps[:, index], np.ascontiguousarray(a, dtype=float), drive, p.cooling,
                               p.filter_gain, float(first_temperatures(series, sensors)[index]), on, off)
    state = np.zeros(series.rows)
    window = max(2, int(RELAY_LOOKAHEAD_S / series.dt))
    y, cooling, j = first_temperatures(series, sensors)[index], False, 0
    while j < series.rows:
        stop = min(j + window, series.rows)
        trajectory = lag(drive[j:stop] + (p.cooling if cooling else 0.0), a[j:stop], y)
        crossing = np.flatnonzero(trajectory < off if cooling else trajectory > on)
        end = j + int(crossing[0]) + 1 if len(crossing) else stop  # the new state acts from the next row
        state[j:end] = cooling
        y = trajectory[end - j - 1]
        cooling = cooling != bool(len(crossing))
        j = end
    return state


@kernels.jit
def _filtered_relay(reading, a, drive, cooling, gain, start, on, off):
    """The relay state per row under the filter, as the block runs it: the filtered temperature of the
    switching sensor (corrected by its reading each row) switches the coolant from the next row."""
    state = np.zeros(len(reading))
    x, cool = start, False
    for j in range(len(reading)):
        state[j] = 1.0 if cool else 0.0
        x = a[j] * x + (1.0 - a[j]) * (drive[j] + (cooling if cool else 0.0))
        x = x + gain * (reading[j] - x)
        if x > on:
            cool = True
        elif x < off:
            cool = False
    return state


def _poles(series: Series, shared: Shared, p: SensorParams):
    a_run = pole(p.tau_s, series.dt)
    if p.stop_factor == 1.0:
        return a_run
    return np.where(stopped(series, shared), pole(p.tau_s * p.stop_factor, series.dt), a_run)


def _heat_inputs(series: Series, shared: Shared, effects, cooling: np.ndarray | None = None
                 ) -> list[tuple[str, np.ndarray]]:
    """Heat input columns; the coolant relay state is `cooling` when given (the closed loop),
    else switched by the measured temperature (a fast stand-in while its thresholds are searched)."""
    names = {e for e, _ in effects}
    inputs = [("gain", speed_heat(series.n, shared)), ("load_K", np.ones(series.rows))]
    if "gear_ratio_switch" in names:
        inputs.append(("gear_gain", np.where(series.n > shared.gear_rpm, series.n, 0.0)))
    if "coolant_switching" in names and shared.relay is not None:  # None while the thresholds are unknown
        sensor, on, off = shared.relay
        inputs.append(("cooling", relay(series.temps[:, sensor], on, off) if cooling is None else cooling))
    return inputs


def _sensor_design(series: Series, i: int, shared: Shared, effects, a, cooling=None):
    """Known part of sensor i's reading and the columns its linear parameters multiply."""
    first = series.temps[0, i] - series.te[0]
    decay = lag(np.zeros(series.rows), a, 1.0)
    known = lag(series.te, a, series.te[0]) + decay * first
    columns = [(name, lag(x, a, 0.0)) for name, x in _heat_inputs(series, shared, effects, cooling)]
    if ("sensor_offset", i) in effects:
        columns.append(("offset_K", 1.0 - decay))
    if ("sensor_drift", i) in effects:
        columns.append(("drift_K_per_s", series.t - series.t[0]))
    return known, columns


def _solve(y: np.ndarray, columns: list[np.ndarray]):
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


def _sensor_cost(series, i, shared, effects, tau_s, factor, cooling=None):
    p = SensorParams(tau_s, 0.0, factor)
    known, columns = _sensor_design(series, i, shared, effects, _poles(series, shared, p), cooling)
    coef, sse = _solve(series.temps[:, i] - known, [c for _, c in columns])
    return sse, replace(p, **{name: float(v) for (name, _), v in zip(columns, coef)})


def fit_sensor(series: Series, i: int, shared: Shared, effects, start: SensorParams | None = None, cooling=None):
    """Time constant (and standstill factor) by search; gains, offset, drift by least squares."""
    has_stop = any(e == "stop_convection" for e, _ in effects)
    dt = series.dt
    low, high = np.log(2 * dt), np.log(72 * HOUR)

    def cost(x):
        tau = float(np.exp(np.clip(x[0], low, high)))
        factor = float(np.exp(np.clip(x[1], -2.5, 2.5))) if has_stop else 1.0
        return _sensor_cost(series, i, shared, effects, tau, factor, cooling)[0]

    # the whole grid even from a warm start: an effect the start lacked (a drift) may have bent its
    # time constant far from the truth
    grid = list(np.linspace(np.log(120.0), np.log(24 * HOUR), 12))
    factor0 = np.log(start.stop_factor) if start is not None else 0.0
    if start is not None:
        grid.append(np.log(start.tau_s))
    x0 = [min(grid, key=lambda g: cost([g, factor0])), factor0]
    if has_stop:
        starts = [[x0[0], f] for f in (-1.0, 0.0, 0.7, 1.4)]
        x0 = min(starts, key=cost)
        result = minimize(cost, x0, method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-10, "maxiter": 300})
        x = result.x
    else:
        result = minimize_scalar(lambda g: cost([g, 0.0]), bounds=(max(low, x0[0] - 1.5), min(high, x0[0] + 1.5)),
                                 method="bounded", options={"xatol": 1e-5})
        x = [result.x, 0.0]
    tau = float(np.exp(np.clip(x[0], low, high)))
    factor = float(np.exp(np.clip(x[1], -2.5, 2.5))) if has_stop else 1.0
    sse, params = _sensor_cost(series, i, shared, effects, tau, factor, cooling)
    return params, sse


def _fit_all_sensors(series, shared, effects, starts, cooling=None):
    fitted = [fit_sensor(series, i, shared, effects, starts[i] if starts else None, cooling)
              for i in range(len(series.names))]
    return tuple(p for p, _ in fitted), sum(sse for _, sse in fitted)


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


def _held_cost(series: Series, shared: Shared, effects, sensors) -> float:
    """Squared error of every sensor with its time constants held (gains by least squares)."""
    return sum(_sensor_cost(series, i, shared, effects, p.tau_s, p.stop_factor)[0] for i, p in enumerate(sensors))


def _search_shared(series, shared, effects, starts, without: str, options, apply):
    """A shared parameter (`options` a list, or a (low, high) interval) searched with the time
    constants held, then the time constants refitted with it, `SEARCH_ROUNDS` times: refitting
    every sensor's time constant for every candidate value costs tens of seconds."""
    held = starts or _fit_all_sensors(series, shared, [e for e in effects if e[0] != without], None)[0]
    chosen = None
    for _ in range(SEARCH_ROUNDS):
        cost = lambda value: _held_cost(series, apply(shared, value), effects, held)
        if isinstance(options, tuple):
            value = float(minimize_scalar(cost, bounds=options, method="bounded", options={"xatol": 1e-3}).x)
        else:
            value = float(min(options, key=cost))
        if chosen is not None and abs(value - chosen) <= 1e-3 * max(abs(chosen), 1.0):
            break
        chosen = value
        held = _fit_all_sensors(series, apply(shared, chosen), effects, held)[0]
    return apply(shared, chosen)


def fit_temperatures(series: Series, shared: Shared, effects, starts=None):
    """Shared parameters (gear threshold, exponent, coolant thresholds) by search, sensors inside."""
    names = {e for e, _ in effects}
    if "gear_ratio_switch" in names:
        levels = speed_levels(series.n, shared)
        if len(levels) > 1:
            shared = _search_shared(series, shared, effects, starts, "gear_ratio_switch", list(levels[:-1]),
                                    lambda s, v: replace(s, gear_rpm=float(v)))
        else:
            shared = replace(shared, gear_rpm=0.0)
    if "nonlinear_speed_heat" in names:
        running = series.n[series.n > shared.stopped_rpm]
        top = float(np.max(running)) if len(running) else 1.0
        shared = replace(shared, reference_rpm=float(np.median(running)) if len(running) else 1.0,
                         table_rpm=tuple(np.linspace(0.0, 1.25 * top, TABLE_SEGMENTS + 1)))
        shared = _search_shared(series, shared, effects, starts, "nonlinear_speed_heat", EXPONENT_RANGE,
                                lambda s, v: replace(s, exponent=float(v)))
    if "coolant_switching" in names:
        shared, sensors = _fit_relay(series, shared, effects, starts)
        cooling = closed_loop_cooling(series, shared, sensors, effects)
        return (shared, *_fit_all_sensors(series, shared, effects, sensors, cooling))
    return (shared, *_fit_all_sensors(series, shared, effects, starts))


def _fit_relay(series, shared, effects, starts):
    """Thresholds by grid with the time constants held, then the time constants with the thresholds
    held, alternating: the cooling shortens the apparent time constant, so both must move. The
    grid switches the relay by the measured temperature (fast); the last rounds switch it by the
    simulated one (the closed loop the model runs) and move the thresholds and sensors with it.
    Returns the shared parameters and the sensors fitted with the closed-loop relay."""
    sensor = next(s for e, s in effects if e == "coolant_switching")
    temperature = savgol_filter(series.temps[:, sensor], RELAY_SMOOTHING_ROWS, 2) if series.rows > RELAY_SMOOTHING_ROWS else series.temps[:, sensor]
    # the cost is spiky in the thresholds (a relay switched by a noisy reading trips on single
    # samples): a grid as fine as the noise finds the right basin where 16 levels missed it
    low, high = np.quantile(temperature, [0.02, 0.995])
    levels = np.linspace(low, high, int(np.clip((high - low) / RELAY_GRID_STEP_K, 16, RELAY_GRID_LEVELS)))
    pairs = [(on, off) for on, off in itertools.product(levels, levels) if on - off >= 0.5]
    if not pairs:
        shared = replace(shared, relay=(sensor, float(levels[-1]), float(levels[0])))
        return shared, _fit_all_sensors(series, shared, effects, starts, relay(temperature, *shared.relay[1:]))[0]
    sensors = starts or _fit_all_sensors(series, shared, [e for e in effects if e[0] != "coolant_switching"], None)[0]

    def prepared():  # everything but the cooling column, per sensor, for the time constants held
        out = []
        for i, p in enumerate(sensors):
            a = _poles(series, shared, p)
            known, columns = _sensor_design(series, i, replace(shared, relay=None), effects, a)
            out.append((a, *_Projection.of(series.temps[:, i] - known, [c for _, c in columns])))
        return out

    def cost_of(state):
        return sum(_added_column_sse(basis, y_perp, lag(state, a, 0.0)) for a, basis, y_perp in parts)

    measured = lambda on, off: cost_of(relay(temperature, on, off))
    closed = lambda on, off: cost_of(closed_loop_cooling(series, replace(shared, relay=(sensor, on, off)), sensors,
                                                         effects))
    step = max(float(np.ptp(temperature)) / 100, 0.01)
    chosen = None
    a, basis, y_perp = prepared()[sensor]  # the grid scores the switch sensor alone (the others follow it)
    on, off = min(pairs, key=lambda pair: _added_column_sse(basis, y_perp, lag(relay(temperature, *pair), a, 0.0)))
    for _ in range(RELAY_ROUNDS):  # the whole grid once; later rounds move the thresholds near it
        parts = prepared()
        on, off = _centred(on, off, step, measured)
        if chosen == (on, off):
            break
        chosen = (on, off)
        shared = replace(shared, relay=(sensor, float(on), float(off)))
        sensors = _fit_all_sensors(series, shared, effects, None, relay(temperature, on, off))[0]
    for _ in range(CLOSED_LOOP_ROUNDS):
        parts = prepared()
        for reach, points in ((4.0, 17), (0.5, 11)):  # coarse, then fine: the measured relay trips early
            on, off = _centred(on, off, step, closed, reach, passes=2, points=points)
        shared = replace(shared, relay=(sensor, float(on), float(off)))
        sensors = _fit_all_sensors(series, shared, effects, sensors,
                                   closed_loop_cooling(series, shared, sensors, effects))[0]
    return shared, sensors


def _centred(on: float, off: float, step: float, cost, reach: float = 8, passes: int = 2, points: int = 64
             ) -> tuple[float, float]:
    """Each threshold to the middle of its best plateau within `reach` steps (the cost is flat between data)."""
    for _ in range(passes):
        grid = lambda centre: np.linspace(centre - reach * step, centre + reach * step, points)
        on = _plateau_centre(grid(on), lambda v: cost(v, min(off, v - 0.5)))
        off = _plateau_centre(grid(off), lambda v: cost(max(on, v + 0.5), v))
        off = min(off, on - 0.5)
    return on, off


class _Projection:
    """The fixed columns' orthonormal basis and the target's part outside it: the squared error with
    one more column then costs two dot products per row instead of a new least-squares solve."""

    @staticmethod
    def of(y: np.ndarray, columns: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        basis, _ = np.linalg.qr(np.column_stack(columns))
        return basis, y - basis @ (basis.T @ y)


def _added_column_sse(basis: np.ndarray, y_perp: np.ndarray, column: np.ndarray) -> float:
    c_perp = column - basis @ (basis.T @ column)
    norm = float(c_perp @ c_perp)
    base = float(y_perp @ y_perp)
    if norm <= 1e-12 * max(float(column @ column), 1e-300):  # the column adds nothing new
        return base
    return base - float(c_perp @ y_perp) ** 2 / norm


def _plateau_centre(values: np.ndarray, cost) -> float:
    costs = np.array([cost(v) for v in values])
    best = int(np.argmin(costs))
    flat = costs <= costs[best] * (1 + 1e-9) + 1e-12
    low = high = best
    while low > 0 and flat[low - 1]:
        low -= 1
    while high < len(values) - 1 and flat[high + 1]:
        high += 1
    return float((values[low] + values[high]) / 2)


def temperatures(series: Series, sim_shared: Shared, sensors, effects) -> tuple[np.ndarray, np.ndarray]:
    """Simulated sensor readings and the physical temperatures they read, (rows, sensors) each.

    Ambient and heat share each sensor's pole, so one lag of (Te + q) started at the first
    physical temperature is their sum (and the form the block computes)."""
    readings = np.empty_like(series.temps)
    physical = np.empty_like(series.temps)
    start, drives = _drives(series, sim_shared, sensors, effects)
    for i, (p, (a, q)) in enumerate(zip(sensors, drives)):
        if p.filter_gain:  # the reading's one-step prediction and the filtered temperature
            readings[:, i], physical[:, i] = filtered(series.temps[:, i], a, series.te + q, p.filter_gain, start[i])
            continue
        physical[:, i] = lag(series.te + q, a, start[i])
        readings[:, i] = physical[:, i] + p.offset_K + p.drift_K_per_s * (series.t - series.t[0])
    return readings, physical


def filtered(reading: np.ndarray, a, drive: np.ndarray, gain: float, start: float) -> tuple[np.ndarray, np.ndarray]:
    """One sensor under the steady-state Kalman filter with gain `gain`: the simulation predicts
    x[j|j-1] = a x[j-1|j-1] + (1-a) drive[j], the reading corrects it, x[j|j] = x[j|j-1] +
    gain (y[j] - x[j|j-1]), from x[-1|-1] = start. Returns (predictions, filtered temperatures).
    Both are one lag of pole a (1 - gain), which runs at lfilter speed; gain 0 is the open loop."""
    pole_ = a * (1.0 - gain)
    previous = np.r_[start, reading[:-1]]
    predicted = lag((a * gain * previous + (1.0 - a) * drive) / (1.0 - pole_), pole_, start)
    return predicted, predicted + gain * (reading - predicted)


def _drives(series: Series, shared: Shared, sensors, effects) -> tuple[np.ndarray, list]:
    """The physical start temperatures, and per sensor its pole(s) and heat input (the coolant relay
    switched by the simulated temperature)."""
    cooling = closed_loop_cooling(series, shared, sensors, effects) if shared.relay is not None else None
    inputs = _heat_inputs(series, shared, effects, cooling)
    return first_temperatures(series, sensors), [
        (_poles(series, shared, p), sum(getattr(p, name) * x for name, x in inputs)) for p in sensors]


def ambient_and_heat_parts(series: Series, sim: Simulation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The physical temperatures split into what the ambient drives (started at the first physical
    temperature) and what the machine's heat drives (started at zero), with the start temperatures.
    The two share each sensor's pole, so they add up to `temperatures` (to rounding)."""
    ambient = np.empty_like(series.temps)
    heat = np.empty_like(series.temps)
    start, drives = _drives(series, sim.shared, sim.sensors, sim.effects)
    for i, (a, q) in enumerate(drives):
        ambient[:, i] = lag(series.te, a, start[i])
        heat[:, i] = lag(q, a, 0.0)
    return ambient, heat, start


def term_columns(series: Series, sim: Simulation, name: str, temps: np.ndarray, start: np.ndarray) -> np.ndarray:
    """The columns of displacement effect `name`'s term for these temperatures (from `start`), before its weights."""
    count = temps.shape[1] if definition_of(name).displacement.per_sensor else 1
    taus = {**_fitted_taus(sim, series), "t0": start}
    return np.column_stack(_displacement_columns(series, temps, taus, ((name, None),))[-count:])


def displacement_terms(effects=None) -> list[DisplacementTerm]:
    """The displacement terms these effects add (every effect's when None), in the order of their
    records (the columns' order)."""
    names = None if effects is None else {e for e, _ in effects}
    return [record.displacement for name, record in registry().items()
            if record.displacement and (names is None or name in names)]


def _displacement_columns(series, temps, taus: dict, effects):
    """Rises of the simulated temperatures (ambient part included), of the structures lagging them,
    and each displacement effect's columns (its record's term)."""
    t0 = taus["t0"]  # physical temperatures before the first row
    k = temps.shape[1]
    columns = [temps[:, i] - t0[i] for i in range(k)]
    lagged = temps
    if taus["struct"] is not None:
        lagged = lag_columns(temps, pole(taus["struct"], series.dt), t0)
        columns += [lagged[:, i] - t0[i] for i in range(k)]
    for term in displacement_terms(effects):
        columns += term.columns(series, temps, lagged, t0, taus[term.key])
    return columns


def fit_displacement(series: Series, temps: np.ndarray, t0: np.ndarray, effects, structure_lag: bool = True,
                     start: DisplacementParams | None = None) -> tuple[DisplacementParams, float]:
    """The displacement's time constants by grid search and polish, its weights by least squares on `temps`
    (rises from `t0`); returns them and the squared error, starting from `start`'s time constants."""
    terms = displacement_terms(effects)
    wanted = (["struct"] if structure_lag else []) + [term.key for term in terms]
    bounds = {"struct": (np.log(600.0), np.log(48 * HOUR)),
              **{term.key: (np.log(term.search_s[0]), np.log(term.search_s[1])) for term in terms}}
    known = {}
    if start is not None:
        known = {"struct": start.tau_struct_s, **{term.key: getattr(start, term.tau_field) for term in terms}}
    k = temps.shape[1]

    def taus_of(x):
        taus = {"t0": t0, "struct": None, **{name: float(np.exp(np.clip(v, *bounds[name]))) for name, v in zip(wanted, x)}}
        for term in terms:  # e.g. a slow lag kept well above the structure's, so the two cannot swap roles
            if term.lowest_s is not None:
                taus[term.key] = max(taus[term.key], term.lowest_s(taus["struct"]))
        return taus

    def cost(x):
        columns = [np.ones(series.rows)] + _displacement_columns(series, temps, taus_of(x), effects)
        return _solve(series.target, columns)[1]

    # a grid over what is new, jointly with the structure's time constant (a slow lag added to a
    # structure that had settled between the two true time constants must be able to move it)
    axes = []
    for name in wanted:
        values = list(np.linspace(*bounds[name], GRID_POINTS))
        if known.get(name):
            joint = name == "struct" and any(not known.get(w) for w in wanted)
            values = [np.log(known[name])] + (values if joint else [])
        axes.append(values)
    grid = sorted(itertools.product(*axes), key=lambda x: cost(list(x)))
    if len(wanted) == 1:
        lo, hi = bounds[wanted[0]]
        x0 = grid[0][0]
        x = [minimize_scalar(lambda g: cost([g]), bounds=(max(lo, x0 - 1.5), min(hi, x0 + 1.5)),
                             method="bounded", options={"xatol": 1e-5}).x]
    elif wanted:  # the valleys are narrow and curved: polish the best few grid points, keep the best
        polished = [minimize(cost, list(x0), method="Nelder-Mead",
                             options={"xatol": 1e-4, "fatol": 1e-9, "maxiter": 400}) for x0 in grid[:POLISHED_STARTS]]
        x = min(polished, key=lambda result: result.fun).x
    else:
        x = []
    taus = taus_of(x)
    columns = [np.ones(series.rows)] + _displacement_columns(series, temps, taus, effects)
    coef, sse = _solve(series.target, columns)
    return displacement_params(coef, k, taus, terms), sse


def displacement_params(coef, k: int, taus: dict, terms, ridge_weight: float | None = None,
                        chosen_s: float | None = None) -> DisplacementParams:
    """The map's parameters from its coefficients in column order (offset, a weight per sensor, per sensor
    on the structure lag when `taus["struct"]` is set, then each term's) and the time constants."""
    coef = [float(c) for c in coef]
    lagged = k if taus["struct"] is not None else 0
    params = DisplacementParams(tau_struct_s=taus["struct"], beta0=coef[0], beta=tuple(coef[1:1 + k]),
                                gamma=tuple(coef[1 + k:1 + k + lagged]), ridge_weight=ridge_weight,
                                tau_struct_chosen_s=chosen_s)
    rest = coef[1 + k + lagged:]
    for term in terms:
        count = k if term.per_sensor else 1
        weights = tuple(rest[:count]) if term.per_sensor else rest[0]
        params = replace(params, **{term.tau_field: taus[term.key], term.weight_field: weights})
        rest = rest[count:]
    return params


def first_temperatures(series: Series, sensors) -> np.ndarray:
    """Physical temperature at each sensor before the first row: its first reading less the offset."""
    return np.array([series.temps[0, i] - p.offset_K for i, p in enumerate(sensors)])


def fit(series: Series, effects=(), warm: Simulation | None = None, structure_lag: bool = True,
        polish: bool = False) -> Simulation:
    """Fit the simulation with these effects on `series` (the training part). A warm start keeps
    its structure-lag choice; `polish` searches its shared parameters and temperatures again even
    when no sensor effect is added (a search started from the previous fit goes further)."""
    effects = tuple(effects)
    shared = Shared(stopped_rpm=stopped_threshold(series.n))
    starts = None
    if warm is not None:
        shared = replace(warm.shared, stopped_rpm=shared.stopped_rpm)
        starts = warm.sensors
        structure_lag = warm.displacement.tau_struct_s is not None
    added = {name for name, _ in effects} - {name for name, _ in warm.effects} if warm is not None and not polish \
        else None
    if added is not None and added <= with_part("displacement"):  # the temperatures do not change
        sensors = warm.sensors
    elif added is not None and added <= with_part("reading"):  # only that sensor changes
        sensors = tuple(fit_sensor(series, i, shared, effects, p)[0] if any(s == i for n, s in effects if n in added)
                        else p for i, p in enumerate(warm.sensors))
    else:
        shared, sensors, _ = fit_temperatures(series, shared, effects, starts)
    _, temps = temperatures(series, shared, sensors, effects)
    displacement, _ = fit_displacement(series, temps, first_temperatures(series, sensors), effects, structure_lag,
                                       warm.displacement if warm is not None else None)
    return Simulation(effects, shared, sensors, displacement)


def stopped_threshold(n: np.ndarray) -> float:
    """Speeds at or below 1 % of the highest speed count as standing (sensor noise at standstill)."""
    return 0.01 * max(float(np.max(np.abs(n))), 1.0)


def _fitted_taus(sim: Simulation, series: Series) -> dict:
    d = sim.displacement
    return {"t0": first_temperatures(series, sim.sensors), "struct": d.tau_struct_s,
            **{term.key: getattr(d, term.tau_field) for term in displacement_terms()}}


def displacement_term(sim: Simulation, series: Series, name: str) -> np.ndarray:
    """What one displacement effect adds to the simulated displacement over `series`."""
    _, temps = temperatures(series, sim.shared, sim.sensors, sim.effects)
    weights = definition_of(name).displacement.weights(sim.displacement)
    columns = _displacement_columns(series, temps, _fitted_taus(sim, series), ((name, None),))
    return sum(w * c for w, c in zip(weights, columns[-len(weights):]))


def run(sim: Simulation, series: Series) -> dict[str, np.ndarray]:
    """Simulated channels over the whole series: each temperature by name, and 'target'."""
    readings, temps = temperatures(series, sim.shared, sim.sensors, sim.effects)
    d = sim.displacement
    columns = _displacement_columns(series, temps, _fitted_taus(sim, series), sim.effects)
    coef = [*d.beta, *d.gamma, *(w for term in displacement_terms(sim.effects) for w in term.weights(d))]
    target = d.beta0 + sum(c * x for c, x in zip(coef, columns))
    out = {name: readings[:, i] for i, name in enumerate(series.names)}
    out["target"] = np.asarray(target, float) * np.ones(series.rows)
    return out
