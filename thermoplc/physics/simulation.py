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

import sys
from dataclasses import replace

import numpy as np

from thermoplc.physics import displacement
from thermoplc.physics.displacement import displacement_columns, displacement_terms, fit_displacement, fitted_taus
from thermoplc.physics.effects import definition_of, registry, with_part
from thermoplc.physics.effects.definition import Routines
from thermoplc.physics.fitted import Simulation
from thermoplc.physics.primitives import (HOUR, Series, SensorParams, Shared, first_temperatures, lag, least_squares,
                                          minimize, minimize_scalar, pole, speed_heat, stopped, stopped_threshold)

SEARCH_ROUNDS = 2  # shared parameter by grid with the time constants held, then the time constants


def sensor_poles(series: Series, shared: Shared, p: SensorParams):
    a_run = pole(p.tau_s, series.dt)
    if p.stop_factor == 1.0:
        return a_run
    return np.where(stopped(series, shared), pole(p.tau_s * p.stop_factor, series.dt), a_run)


def records_with(effects, hook: str) -> list:
    """The records of these effects that have `hook`, by rank."""
    names = {e for e, _ in effects}
    return [record for name, record in registry().items() if name in names and getattr(record, hook)]


def routines() -> Routines:
    """This module and the displacement's, handed to an effect's search (which cannot import them back)."""
    return Routines(simulation=sys.modules[__name__], displacement=displacement)


def closed_loop_of(effects):
    """The record of the closed loop among these effects (the coolant relay), or None."""
    return next(iter(records_with(effects, "closed_loop")), None)


def closed_loop_state(series: Series, shared: Shared, sensors, effects) -> np.ndarray | None:
    """The state per row of the closed loop among the effects, switched by the simulated temperature; None
    without one or while its parameters are unknown."""
    loop = closed_loop_of(effects)
    return None if loop is None else loop.closed_loop(series, shared, sensors, effects, routines())


def heat_inputs(series: Series, shared: Shared, effects, cooling: np.ndarray | None = None
                ) -> list[tuple[str, np.ndarray]]:
    """Heat input columns: the speed heat, the standstill load and each heat effect's (its record's
    `heat_input`); a closed loop's state is `cooling` when given, else its record's stand-in."""
    inputs = [("gain", speed_heat(series.n, shared)), ("load_K", np.ones(series.rows))]
    for record in records_with(effects, "heat_input"):
        column = record.heat_input(series, shared, cooling)
        if column is not None:
            inputs.append(column)
    return inputs


def sensor_design(series: Series, i: int, shared: Shared, effects, a, cooling=None):
    """Known part of sensor i's reading and the columns its linear parameters multiply."""
    first = series.temps[0, i] - series.te[0]
    decay = lag(np.zeros(series.rows), a, 1.0)
    known = lag(series.te, a, series.te[0]) + decay * first
    columns = [(name, lag(x, a, 0.0)) for name, x in heat_inputs(series, shared, effects, cooling)]
    for record in records_with(effects, "reading_column"):  # an error of this sensor's reading (offset, drift)
        if (record.name, i) in effects:
            columns.append(record.reading_column(series, decay))
    return known, columns


def _sensor_cost(series, i, shared, effects, tau_s, factor, cooling=None):
    p = SensorParams(tau_s, 0.0, factor)
    known, columns = sensor_design(series, i, shared, effects, sensor_poles(series, shared, p), cooling)
    coef, sse = least_squares(series.temps[:, i] - known, [c for _, c in columns])
    return sse, replace(p, **{name: float(v) for (name, _), v in zip(columns, coef)})


def fit_sensor(series: Series, i: int, shared: Shared, effects, start: SensorParams | None = None, cooling=None):
    """Time constant (and standstill factor) by search; gains, offset, drift by least squares."""
    has_stop = any(definition_of(e).part == "pole" for e, _ in effects)  # a standstill factor (stop_convection)
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


def fit_all_sensors(series, shared, effects, starts, cooling=None):
    fitted = [fit_sensor(series, i, shared, effects, starts[i] if starts else None, cooling)
              for i in range(len(series.names))]
    return tuple(p for p, _ in fitted), sum(sse for _, sse in fitted)


def _held_cost(series: Series, shared: Shared, effects, sensors) -> float:
    """Squared error of every sensor with its time constants held (gains by least squares)."""
    return sum(_sensor_cost(series, i, shared, effects, p.tau_s, p.stop_factor)[0] for i, p in enumerate(sensors))


def held_sensors(series: Series, shared: Shared, effects, sensors) -> tuple[SensorParams, ...]:
    """Every sensor with its time constants held and its gains by least squares (what `_held_cost` fits)."""
    return tuple(_sensor_cost(series, i, shared, effects, p.tau_s, p.stop_factor)[1] for i, p in enumerate(sensors))


def search_shared(series, shared, effects, starts, without: str, options, apply):
    """A shared parameter (`options` a list, or a (low, high) interval) searched with the time
    constants held, then the time constants refitted with it, `SEARCH_ROUNDS` times: refitting
    every sensor's time constant for every candidate value costs tens of seconds."""
    held = starts or fit_all_sensors(series, shared, [e for e in effects if e[0] != without], None)[0]
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
        held = fit_all_sensors(series, apply(shared, chosen), effects, held)[0]
    return apply(shared, chosen)


def fit_temperatures(series: Series, shared: Shared, effects, starts=None):
    """Shared parameters (gear threshold, exponent; a closed loop's thresholds last) by search, sensors inside:
    each effect's record searches its own."""
    for record in records_with(effects, "search_open_loop"):
        shared = record.search_open_loop(series, shared, effects, starts, routines())
    loop = closed_loop_of(effects)
    if loop is not None:
        shared, sensors = loop.fit_closed_loop(series, shared, effects, starts, routines())
        cooling = loop.closed_loop(series, shared, sensors, effects, routines())
        return (shared, *fit_all_sensors(series, shared, effects, sensors, cooling))
    return (shared, *fit_all_sensors(series, shared, effects, starts))


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
    """The physical start temperatures, and per sensor its pole(s) and heat input (a closed loop switched by
    the simulated temperature)."""
    cooling = closed_loop_state(series, shared, sensors, effects)
    inputs = heat_inputs(series, shared, effects, cooling)
    return first_temperatures(series, sensors), [
        (sensor_poles(series, shared, p), sum(getattr(p, name) * x for name, x in inputs)) for p in sensors]


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
    weights, _ = fit_displacement(series, temps, first_temperatures(series, sensors), effects, structure_lag,
                                  warm.displacement if warm is not None else None)
    return Simulation(effects, shared, sensors, weights)


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
