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
from dataclasses import replace

import numpy as np

from thermoplc.base import compiled
from thermoplc.physics.displacement import displacement_columns, displacement_terms, fit_displacement, fitted_taus
from thermoplc.physics.effects import definition_of, with_part
from thermoplc.physics.model import Simulation
from thermoplc.physics.primitives import (HOUR, Series, SensorParams, Shared, first_temperatures, lag, least_squares,
                                          minimize, minimize_scalar, pole, relay, savgol_filter, speed_heat,
                                          speed_levels, stopped, stopped_threshold)

TABLE_SEGMENTS = 16
RELAY_ROUNDS = 4
RELAY_GRID_STEP_K = 0.05
RELAY_GRID_LEVELS = 80
RELAY_SMOOTHING_ROWS = 9
RELAY_LOOKAHEAD_S = 7200.0
CLOSED_LOOP_ROUNDS = 2  # relay state from the simulation, sensors refitted with it
EXPONENT_RANGE = (0.2, 3.5)
SEARCH_ROUNDS = 2  # shared parameter by grid with the time constants held, then the time constants


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


@compiled.jit
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


def _sensor_cost(series, i, shared, effects, tau_s, factor, cooling=None):
    p = SensorParams(tau_s, 0.0, factor)
    known, columns = _sensor_design(series, i, shared, effects, _poles(series, shared, p), cooling)
    coef, sse = least_squares(series.temps[:, i] - known, [c for _, c in columns])
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


def displacement_term(sim: Simulation, series: Series, name: str) -> np.ndarray:
    """What one displacement effect adds to the simulated displacement over `series`."""
    _, temps = temperatures(series, sim.shared, sim.sensors, sim.effects)
    weights = definition_of(name).displacement.weights(sim.displacement)
    columns = displacement_columns(series, temps, fitted_taus(sim, series), ((name, None),))
    return sum(w * c for w, c in zip(weights, columns[-len(weights):]))


def run(sim: Simulation, series: Series) -> dict[str, np.ndarray]:
    """Simulated channels over the whole series: each temperature by name, and 'target'."""
    readings, temps = temperatures(series, sim.shared, sim.sensors, sim.effects)
    d = sim.displacement
    columns = displacement_columns(series, temps, fitted_taus(sim, series), sim.effects)
    coef = [*d.beta, *d.gamma, *(w for term in displacement_terms(sim.effects) for w in term.weights(d))]
    target = d.beta0 + sum(c * x for c, x in zip(coef, columns))
    out = {name: readings[:, i] for i, name in enumerate(series.names)}
    out["target"] = np.asarray(target, float) * np.ones(series.rows)
    return out
