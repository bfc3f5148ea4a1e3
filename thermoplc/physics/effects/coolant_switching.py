"""Coolant switching: extra cooling switched on and off at temperature thresholds (hysteresis).

Term: one more heat input per sensor, `cooling * state`, the relay switched by the simulated
temperature of one sensor (tried on each); the thresholds are searched, then the lag the cooling
reaches the sensors through (a coolant loop's fluid and exchanger have a thermal mass of their own;
0 when it acts at once) on a bounded grid. A closed loop: the relay's
state follows the simulated temperature it cools, so the simulation asks this record for it
(`closed_loop`), and its thresholds are searched with the sensors refitted around them, open loop
(`fit_closed_loop`) and on the identified model (`search_identified`)."""
from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from thermoplc.base import compiled
from thermoplc.physics.effects.definition import EffectDefinition
from thermoplc.physics.primitives import (Series, Shared, first_temperatures, lag, lag_columns, minimize_scalar, pole,
                                         savgol_filter)

MIN_RELAY_SWITCHES = 3  # on, off, on: one cycle and the start of another
RELAY_ROUNDS = 4
RELAY_GRID_STEP_K = 0.05
RELAY_GRID_LEVELS = 80
RELAY_SMOOTHING_ROWS = 9
RELAY_LOOKAHEAD_S = 7200.0
CLOSED_LOOP_ROUNDS = 2  # relay state from the simulation, sensors refitted with it
LAG_GRID_S = (0.0, 300.0, 600.0, 1200.0, 2400.0, 4800.0)  # the cooling's own lag: none, then 5 min .. 80 min
LAG_ROUNDS = 12  # rounds of thresholds and lag in turn; they settle within 10 on the twins
LAG_SETTLED = 0.02  # the lag moved less than this share of itself: settled


def check(parameters: dict) -> str | None:
    if not parameters["on_C"] > parameters["off_C"]:
        return (f"on_C ({parameters['on_C']:g}) must be above off_C ({parameters['off_C']:g}): "
                "the relay's hysteresis")
    return None


def describe(sim, series) -> dict:
    s = sim.shared
    return {"switch_sensor": series.names[s.relay[0]], "on_C": s.relay[1], "off_C": s.relay[2],
            "lag_min": s.cool_tau_s / 60.0, "cooling_K": {c: p.cooling for c, p in zip(series.names, sim.sensors)}}


def draw(rng: np.random.Generator, clean: dict, train: slice, machine) -> dict:
    """On between the 55th and 80th percentile of the switch sensor's training temperatures, off
    1.5-4 K below: the relay switches several times; cooling 2-6 K of steady rise."""
    t = clean[machine.COOLANT_SENSOR][train]
    on = float(np.quantile(t, rng.uniform(0.55, 0.8)))
    gap = min(rng.uniform(1.5, 4.0), 0.8 * (on - float(np.quantile(t, 0.1))))
    return {"on_C": on, "off_C": on - max(gap, 0.5), "cooling_K": float(rng.uniform(2.0, 6.0))}


def twin_pole(effect, dt: float) -> float:
    """A synthetic machine's pole of the cooling's own lag (`lag_min`; 0 when the cooling acts at once)."""
    return _pole_or_none(effect.get("lag_min") * 60.0, dt)


def implausible(sim, train, routines) -> str | None:
    if sim.sensors[sim.shared.relay[0]].cooling >= 0:
        return "the switched term heats the sensor that switches it"
    return None


def too_quiet(sim, train, routines) -> str | None:
    """A fitted coolant relay that switches too rarely in training is a step, not a coolant."""
    state = closed_loop_cooling(train, sim.shared, sim.sensors, sim.effects, routines)
    switches = int(np.count_nonzero(np.diff(np.r_[0.0, state])))
    if switches < MIN_RELAY_SWITCHES:
        return (f"the fitted relay switches {switches} time(s) in the training part; at least {MIN_RELAY_SWITCHES} "
                f"are needed to tell a coolant from a one-off change")
    return None


def relay(temperature: np.ndarray, on: float, off: float) -> np.ndarray:
    """Coolant state used at each row: switched by the temperatures of the rows before (hysteresis)."""
    above, below = temperature > on, temperature < off
    events = np.where(above | below, np.arange(len(temperature)), -1)
    last = np.maximum.accumulate(events)
    state = np.where(last >= 0, above[np.maximum(last, 0)], False)
    return np.r_[False, state[:-1]].astype(float)


def heat_input(series: Series, shared: Shared, state) -> tuple[str, np.ndarray] | None:
    """The cooling column: the relay's closed-loop `state` when given, else switched by the measured
    temperature (a fast stand-in while its thresholds are searched), through the cooling's lag from 0 (the
    block's LC starts at 0); none while the thresholds are unknown."""
    if shared.relay is None:
        return None
    sensor, on, off = shared.relay
    return "cooling", lagged(relay(series.temps[:, sensor], on, off) if state is None else state, shared, series.dt)


def lagged(state: np.ndarray, shared: Shared, dt: float) -> np.ndarray:
    """The relay's state through the cooling's own lag, from 0; the state itself when it acts at once."""
    return lag(state, cooling_pole(shared, dt), 0.0) if shared.cool_tau_s > 0 else state


def cooling_pole(shared: Shared, dt: float) -> float:
    return _pole_or_none(shared.cool_tau_s, dt)


def _pole_or_none(tau_s: float, dt: float) -> float:
    """The pole of a lag of `tau_s`; 0 (the input itself) for none."""
    return pole(tau_s, dt) if tau_s > 0 else 0.0


def closed_loop(series: Series, shared: Shared, sensors, effects, routines) -> np.ndarray | None:
    """The relay's state per row switched by the simulated temperature; None while its thresholds are unknown."""
    return None if shared.relay is None else closed_loop_cooling(series, shared, sensors, effects, routines)


def closed_loop_cooling(series: Series, shared: Shared, sensors, effects, routines) -> np.ndarray:
    """The coolant state per row (1.0 while cooling), switched by the *simulated* temperature of the relay
    sensor: the coolant's controller reacts to the true temperature, which the simulation estimates
    without the sensor noise that would trip a relay early. Between switches the sensor is a
    linear lag, so the state is found switch by switch over windows of `RELAY_LOOKAHEAD_S`."""
    simulation = routines.simulation
    index, on, off = shared.relay
    p = sensors[index]
    a = np.broadcast_to(simulation.sensor_poles(series, shared, p), (series.rows,))
    drive = series.te + sum(getattr(p, name) * x for name, x in simulation.heat_inputs(series, replace(shared, relay=None), effects))
    ac = cooling_pole(shared, series.dt)
    if p.filter_gain:
        return _filtered_relay(series.temps[:, index], np.ascontiguousarray(a, dtype=float), drive, p.cooling,
                               p.filter_gain, float(first_temperatures(series, sensors)[index]), on, off, ac)
    state = np.zeros(series.rows)
    window = max(2, int(RELAY_LOOKAHEAD_S / series.dt))
    y, share, cooling, j = first_temperatures(series, sensors)[index], 0.0, False, 0
    while j < series.rows:
        stop = min(j + window, series.rows)
        shares = lag(np.full(stop - j, 1.0 if cooling else 0.0), ac, share)  # the cooling's lag, from its last share
        trajectory = lag(drive[j:stop] + p.cooling * shares, a[j:stop], y)
        crossing = np.flatnonzero(trajectory < off if cooling else trajectory > on)
        end = j + int(crossing[0]) + 1 if len(crossing) else stop  # the new state acts from the next row
        state[j:end] = cooling
        y, share = trajectory[end - j - 1], shares[end - j - 1]
        cooling = cooling != bool(len(crossing))
        j = end
    return state


@compiled.jit
def _filtered_relay(reading, a, drive, cooling, gain, start, on, off, ac):
    """The relay state per row under the filter, as the block runs it: the filtered temperature of the
    switching sensor (corrected by its reading each row) switches the coolant from the next row; the
    cooling reaches it through its lag of pole `ac` (0: at once)."""
    state = np.zeros(len(reading))
    x, share, cool = start, 0.0, False
    for j in range(len(reading)):
        state[j] = 1.0 if cool else 0.0
        share = ac * share + (1.0 - ac) * state[j]
        x = a[j] * x + (1.0 - a[j]) * (drive[j] + cooling * share)
        x = x + gain * (reading[j] - x)
        if x > on:
            cool = True
        elif x < off:
            cool = False
    return state


def fit_closed_loop(series, shared, effects, starts, routines):
    """Thresholds by grid with the time constants held, then the time constants with the thresholds
    held, alternating: the cooling shortens the apparent time constant, so both must move. The
    grid switches the relay by the measured temperature (fast); the last rounds switch it by the
    simulated one (the closed loop the model runs) and move the thresholds and sensors with it.
    Returns the shared parameters and the sensors fitted with the closed-loop relay."""
    simulation = routines.simulation
    sensor, shared = next(s for e, s in effects if e == "coolant_switching"), _with_lag(shared, 0.0)
    temperature = savgol_filter(series.temps[:, sensor], RELAY_SMOOTHING_ROWS, 2) if series.rows > RELAY_SMOOTHING_ROWS else series.temps[:, sensor]
    # the cost is spiky in the thresholds (a relay switched by a noisy reading trips on single
    # samples): a grid as fine as the noise finds the right basin where 16 levels missed it
    low, high = np.quantile(temperature, [0.02, 0.995])
    levels = np.linspace(low, high, int(np.clip((high - low) / RELAY_GRID_STEP_K, 16, RELAY_GRID_LEVELS)))
    pairs = [(on, off) for on, off in itertools.product(levels, levels) if on - off >= 0.5]
    if not pairs:
        shared = replace(shared, relay=(sensor, float(levels[-1]), float(levels[0])))
        return shared, simulation.fit_all_sensors(series, shared, effects, starts, relay(temperature, *shared.relay[1:]))[0]
    sensors = starts or simulation.fit_all_sensors(series, shared, [e for e in effects if e[0] != "coolant_switching"], None)[0]

    def prepared():  # everything but the cooling column, per sensor, for the time constants held
        out = []
        for i, p in enumerate(sensors):
            a = simulation.sensor_poles(series, shared, p)
            known, columns = simulation.sensor_design(series, i, replace(shared, relay=None), effects, a)
            out.append((a, *_Projection.of(series.temps[:, i] - known, [c for _, c in columns])))
        return out

    def cost_of(state):
        return sum(_added_column_sse(basis, y_perp, lag(state, a, 0.0)) for a, basis, y_perp in parts)

    measured = lambda on, off: cost_of(relay(temperature, on, off))
    closed = lambda on, off: cost_of(lagged(closed_loop_cooling(series, replace(shared, relay=(sensor, on, off)),
                                                                sensors, effects, routines), shared, series.dt))
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
        sensors = simulation.fit_all_sensors(series, shared, effects, None, relay(temperature, on, off))[0]
    def closed_loop_round():
        nonlocal parts, on, off, shared, sensors
        parts = prepared()
        for reach, points in ((4.0, 17), (0.5, 11)):  # coarse, then fine: the measured relay trips early
            on, off = _centred(on, off, step, closed, reach, passes=2, points=points)
        shared = replace(shared, relay=(sensor, float(on), float(off)))
        sensors = simulation.fit_all_sensors(series, shared, effects, sensors,
                                   closed_loop_cooling(series, shared, sensors, effects, routines))[0]

    for _ in range(CLOSED_LOOP_ROUNDS):
        closed_loop_round()
    for _ in range(LAG_ROUNDS):  # the lag at the thresholds, then the thresholds at the lag, until the lag settles
        parts, state = prepared(), closed_loop_cooling(series, shared, sensors, effects, routines)
        tau = _best_lag(lambda tau: cost_of(lagged(state, _with_lag(shared, tau), series.dt)))
        if _settled(tau, shared.cool_tau_s):
            break
        shared = _with_lag(shared, tau)
        closed_loop_round()
    return shared, sensors


def _settled(tau_s: float, previous_s: float) -> bool:
    """Whether the lag moved less than LAG_SETTLED of itself (none stays none)."""
    return abs(tau_s - previous_s) <= LAG_SETTLED * max(previous_s, 1.0)


def _best_lag(cost) -> float:
    """The cooling's lag: the best of LAG_GRID_S, then, when it is not none, polished between its neighbours on the
    grid (log scale, 1 % tolerance): a lag between two grid points leaves a slow misfit either way."""
    costs = [cost(tau) for tau in LAG_GRID_S]
    best = int(np.argmin(costs))
    if best == 0:
        return 0.0
    low, high = LAG_GRID_S[max(best - 1, 1)], LAG_GRID_S[min(best + 1, len(LAG_GRID_S) - 1)]
    found = minimize_scalar(lambda x: cost(float(np.exp(x))), bounds=(np.log(low), np.log(high)), method="bounded",
                            options={"xatol": 0.01})
    return float(np.exp(found.x)) if found.fun < costs[best] else LAG_GRID_S[best]


def _with_lag(shared: Shared, tau_s: float) -> Shared:
    return replace(shared, cool_tau_s=float(tau_s))


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


def _relay_sensor(effects) -> int:
    return next(s for e, s in effects if e == "coolant_switching")


def search_identified(runs: list[Series], shared: Shared, effects, sensors, routines) -> Shared:
    """The coolant thresholds: a grid over the switching sensor's smoothed readings, scored by its one-step
    error with the others' columns projected out (two dot products per row and pair), then each threshold
    moved to the middle of its best plateau; then the cooling's lag on LAG_GRID_S, scored the same way."""
    identify, simulation = routines.identify, routines.simulation
    sensor, shared = _relay_sensor(effects), _with_lag(shared, 0.0)
    p = sensors[sensor]
    smooth = lambda t: savgol_filter(t, RELAY_SMOOTHING_ROWS, 2) if len(t) > RELAY_SMOOTHING_ROWS else t
    readings = [smooth(series.temps[:, sensor]) for series in runs]
    heats = [[x for _, x in inputs] for inputs in identify.heat_inputs(runs, replace(shared, relay=None), effects)]
    y, columns = identify.stacked(runs, sensor, heats, shared, p.tau_s, p.filter_gain, p.stop_factor)
    basis, y_perp = _Projection.of(y, columns)
    poles = [simulation.sensor_poles(series, shared, p) for series in runs]

    def share(a, state: np.ndarray) -> np.ndarray:
        """The cooling column of one run: the share of a unit cooling the one-step prediction carries."""
        if np.ndim(a):
            return simulation.filtered(np.zeros(len(state)), a, state, p.filter_gain, 0.0)[0]
        pole = a * (1.0 - p.filter_gain)  # simulation.filtered with a zero reading, as one lag (the same bits)
        return lag_columns(((1.0 - a) * state / (1.0 - pole))[:, None], pole, np.zeros(1))[:, 0]

    def cost(on: float, off: float, tau_s: float = 0.0) -> float:
        at = _with_lag(shared, tau_s)
        column = np.concatenate([share(a, lagged(relay(t, on, off), at, series.dt))
                                 for a, t, series in zip(poles, readings, runs)])
        return _added_column_sse(basis, y_perp, column)

    every = np.concatenate(readings)
    low, high = np.quantile(every, [0.02, 0.995])
    levels = np.linspace(low, high, int(np.clip((high - low) / RELAY_GRID_STEP_K, 16, RELAY_GRID_LEVELS)))
    pairs = [(on, off) for on, off in itertools.product(levels, levels) if on - off >= 0.5]
    if not pairs:
        return replace(shared, relay=(sensor, float(levels[-1]), float(levels[0])))
    on, off = min(pairs, key=lambda pair: cost(*pair))
    step, tau = max(float(np.ptp(every)) / 100, 0.01), 0.0
    for _ in range(LAG_ROUNDS):  # the thresholds at the lag, then the lag at the thresholds: a lag delays each switch
        on, off = _centred(on, off, step, lambda on_, off_: cost(on_, off_, tau))
        chosen, tau = tau, _best_lag(lambda lag_s: cost(on, off, lag_s))
        if _settled(tau, chosen):
            break
    return _with_lag(replace(shared, relay=(sensor, float(on), float(off))), tau)


EFFECT = EffectDefinition(
    name="coolant_switching", rank=1, bounds=(("on_C", -50.0, 250.0), ("off_C", -50.0, 250.0), ("cooling_K", -100.0, 100.0),
                                              ("lag_min", 0.0, 600.0)),
    description="extra motor cooling switched on/off at temperature thresholds with hysteresis, through a lag of its "
                "own (lag_min, 0: at once)",
    defaults=(("on_C", 27.0), ("off_C", 24.0), ("cooling_K", 4.0), ("lag_min", 0.0)), check=check,
    part="heat", per_sensor=True, added_parameters=lambda sensors: sensors + 3,
    describe=describe, draw=draw, implausible=implausible, after_fit=too_quiet, heat_input=heat_input,
    closed_loop=closed_loop, fit_closed_loop=fit_closed_loop, search_identified=search_identified)
