"""A gantry/portal milling machine with a vertical ram: the second synthetic machine (docs/diagnosis.md).

Written apart from the cascade machine so that a diagnosis tuned on one is judged on the other.
What differs: three measured nodes (front spindle bearing, headstock gearbox, crossbeam surface)
heated in parallel by the spindle speed, an unmeasured ram node lagging a weighted mix of them,
a crossbeam that bends the tool *up* (negative µm/K), a random speed schedule over a continuous
range (200-4000 rpm, both sides of paper 000's 750 rpm), a feed-rate column, and a workshop
whose heating schedule (night setback, warm-up ramp, door openings, slow wander) is no sine.

What stays inside paper 000's class (docs/diagnosis.md) when no effect is on: each measured temperature
is exactly eq. 4's first-order lag of ambient + gain·speed, T[j] = a·T[j-1] + (1 − a)·u[j] with
a = exp(−dt/τ) (the exact step for an input held over the sample), and the displacement is linear
in the measured temperatures plus the ram node (eq. 10/16 through a structure lag). Every named
effect of physics/effects/ is a physical extension on top of that.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from thermoplc.base.errors import UserError
from thermoplc.machines.hall import stepped
from thermoplc.physics.effects import coolant_switching, gear_ratio_switch, registry

NAME = "portal"
DESCRIPTION = "gantry milling machine: spindle, gearbox and crossbeam nodes, unmeasured ram, random speeds"
SENSORS = ("T_spindle", "T_gearbox", "T_column")
DIAGNOSED = SENSORS  # every measured node is given to a diagnosis; the ram is not measured
COOLANT_SENSOR = "T_spindle"  # the relay of coolant_switching reads this node
COLUMN_DEFAULTS = {"sensor_offset": "T_column", "sensor_drift": "T_spindle"}
SPEED_RANGE_RPM = (200.0, 4000.0)


@dataclass(frozen=True)
class Node:
    """A measured lumped mass: steady rise at top speed, time constant, µm/K, weight in the ram mix."""
    name: str
    rise_K: float
    tau_min: float
    um_per_K: float
    ram_weight: float

    @property
    def gain_K_per_rpm(self) -> float:
        return self.rise_K / SPEED_RANGE_RPM[1]


NODES = (Node("T_spindle", 12.0, 25.0, 2.0, 0.5),
         Node("T_gearbox", 8.0, 45.0, 1.0, 0.3),
         Node("T_column", 4.5, 85.0, -3.0, 0.2))   # crossbeam bending pulls the tool up
RAM_TAU_H = 2.5
RAM_UM_PER_K = 4.0
STANDSTILL_RPM = 5.0
FEED_K_PER_MM_MIN = 1e-3            # ball-screw steady rise: 1 K per 1000 mm/min
PT100_NOISE_K = 0.08                # per unit of `noise`
AMBIENT_NOISE_K = 0.05
DISPLACEMENT_NOISE_UM = 0.7
QUANTUM_K = 0.01


def simulate(hours: float, seed: int, dt: float = 10.0, ambient_start: float = 20.0, ambient_swing: float = 1.0,
             faults: tuple = (), constant_rpm: float | None = None, effects: tuple = (),
             noise: float = 1.0, ambient_level: float | None = None,
             ambient_step_s: float = 0.0) -> dict[str, np.ndarray]:
    """Columns of a recording `hours` long every `dt` s; noise=0 gives the exact physics (unquantised); with
    `ambient_level` the hall air moves to it from `ambient_step_s` on (machines/hall.py)."""
    _check_arguments(hours, seed, dt, noise, constant_rpm, faults)
    active = _active_effects(effects)
    schedule, feed, hall, sensors = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(4))
    t = np.arange(int(np.floor(hours * 3600.0 / dt + 1e-9)) + 1) * float(dt)
    n = np.full(t.size, float(constant_rpm)) if constant_rpm is not None else _speed_schedule(t, schedule)
    v = _feed_rate(t, n, feed)
    env = _ambient(t, dt, ambient_start, ambient_swing, hall)
    if ambient_level is not None:
        env = stepped(t, env, ambient_level, ambient_step_s)
    temps = _measured_nodes(n, env, dt, active)
    e_true = _displacement(temps, env, v, dt, active)
    z = sensors.standard_normal((len(SENSORS) + 2, t.size)) * noise
    readings = {"T_env": env + AMBIENT_NOISE_K * z[0]}
    readings.update({name: temps[name] + PT100_NOISE_K * z[1 + i] for i, name in enumerate(SENSORS)})
    _apply_sensor_errors(readings, t, active, faults)
    if noise > 0:
        readings = {name: np.round(x / QUANTUM_K) * QUANTUM_K for name, x in readings.items()}
    return {"time_s": t, "n_rpm": n, "v_feed_mm_min": v, **readings,
            "E_z_um": e_true + DISPLACEMENT_NOISE_UM * z[-1], "E_z_true_um": e_true}


def _lag(u: np.ndarray, a: float | np.ndarray, y0: float) -> np.ndarray:
    """y[0] = y0, y[j] = a[j]·y[j-1] + (1 − a[j])·u[j]; `a` one number or one per sample (each run of
    equal a is filtered at once)."""
    a = np.broadcast_to(np.asarray(a, float), u.shape)
    y = np.empty(u.shape)
    y[0] = y0
    starts = [1, *(np.flatnonzero(np.diff(a[1:])) + 2)]
    for s, e in zip(starts, [*starts[1:], u.size]):
        if s < e:
            k = a[s]
            y[s:e] = lfilter([1.0 - k], [1.0, -k], u[s:e], zi=[k * y[s - 1]])[0]
    return y


def _check_arguments(hours: float, seed: int, dt: float, noise: float, constant_rpm: float | None,
                     faults: tuple) -> None:
    if not hours > 0:
        raise UserError(f"--hours must be above 0, found {hours}")
    if not dt > 0:
        raise UserError(f"--dt must be above 0 s, found {dt}")
    if not noise >= 0:
        raise UserError(f"--noise must be 0 or more, found {noise}")
    if seed < 0:
        raise UserError(f"--seed must be 0 or more, found {seed}")
    if constant_rpm is not None and not 0 <= constant_rpm < np.inf:
        raise UserError(f"constant speed must be 0 rpm or more, found {constant_rpm}")
    for f in faults:
        if f.column not in SENSORS:
            raise UserError(f"sensor fault on {f.column!r}: machine {NAME} has sensors {', '.join(SENSORS)}")


def _active_effects(effects: tuple) -> dict:
    """The effects by name, each checked against this machine."""
    active = {}
    for e in effects:
        if e.name not in registry():
            raise UserError(f"effect {e.name!r}: unknown; expected one of {', '.join(registry())}")
        definition = registry()[e.name]
        if e.name in active:
            raise UserError(f"effect {e.name}: each effect can be switched on once")
        if e.name in COLUMN_DEFAULTS and e.get("column") not in SENSORS:
            raise UserError(f"effect {e.name}: column {e.get('column')!r} is not a sensor of machine {NAME}; "
                            f"expected one of {', '.join(SENSORS)}")
        for key in definition.positive:
            if not e.get(key) > 0:
                raise UserError(f"effect {e.name}: {key} must be above 0, found {e.get(key)}")
        for key, _, _ in definition.bounds:
            if why := definition.out_of_bounds(key, e.get(key)):
                raise UserError(f"effect {e.name}: {why}")
        if why := definition.check(dict(e.parameters)):
            raise UserError(f"effect {e.name}: {why}")
        active[e.name] = e
    return active


def _speed_schedule(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A short stop, then runs of 20 min-3 h at log-uniform speeds (10 rpm steps), each followed by
    a stop of 10 min-2 h or (one time in three) straight by the next speed."""
    starts, speeds = [0.0], [0.0]
    clock = rng.uniform(5.0, 20.0) * 60.0
    low, high = np.log(SPEED_RANGE_RPM)
    while clock <= t[-1]:
        starts.append(clock)
        speeds.append(float(np.round(np.exp(rng.uniform(low, high)) / 10.0) * 10.0))
        clock += rng.uniform(20.0, 180.0) * 60.0
        if rng.uniform() < 2.0 / 3.0:
            starts.append(clock)
            speeds.append(0.0)
            clock += rng.uniform(10.0, 120.0) * 60.0
    return np.asarray(speeds)[np.searchsorted(starts, t, side="right") - 1]


def _feed_rate(t: np.ndarray, n: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Blocks of 2-15 min at 100-3000 mm/min (one in five a dwell at 0) while the spindle turns."""
    count = int(t[-1] / 120.0) + 2
    starts = np.concatenate(([0.0], np.cumsum(rng.uniform(120.0, 900.0, count))))
    rates = np.where(rng.uniform(size=count + 1) < 0.2, 0.0, np.round(rng.uniform(100.0, 3000.0, count + 1), -1))
    return np.where(n >= STANDSTILL_RPM, rates[np.searchsorted(starts, t, side="right") - 1], 0.0)


def _heating(hour: np.ndarray) -> np.ndarray:
    """The hall's daily shape in units of ambient_swing: heated day (a little afternoon warmth),
    setback at 20:00 cooling towards −2, warm-up ramp 05:30-07:00."""
    since_setback = (hour - 20.0) % 24.0
    night = -2.0 * (1.0 - np.exp(-since_setback / 2.5))
    ramp = -2.0 * (1.0 - np.exp(-9.5 / 2.5)) * (7.0 - hour) / 1.5
    day = 0.3 * np.sin(np.pi * (hour - 7.0) / 13.0)
    return np.select([(hour >= 7.0) & (hour < 20.0), (hour >= 5.5) & (hour < 7.0)], [day, ramp], night)


def _ambient(t: np.ndarray, dt: float, start: float, swing: float, rng: np.random.Generator) -> np.ndarray:
    """True hall air: heating schedule from a random clock time, door-opening dips in working hours
    and a slow mean-reverting wander, all scaled by `swing`; equal to `start` at t = 0."""
    hour = (rng.uniform(0.0, 24.0) + t / 3600.0) % 24.0
    shape = _heating(hour) - _heating(hour[:1])
    phi = np.exp(-dt / (12 * 3600.0))
    kicks = rng.standard_normal(t.size) * 0.3 * np.sqrt(1.0 - phi ** 2)
    kicks[0] = 0.0
    wander = lfilter([1.0], [1.0, -phi], kicks)
    opened = rng.uniform(0.0, t[-1], rng.poisson(t[-1] / (6 * 3600.0)))
    depth, width = rng.uniform(0.3, 1.0, opened.size), rng.uniform(300.0, 900.0, opened.size)
    dips = np.zeros(t.size)
    for t0, d, w in zip(opened, depth, width):
        if 6.0 <= hour[np.searchsorted(t, t0)] < 20.0:
            x = np.clip((t - t0) / w, 0.0, None)
            dips -= d * x * np.exp(1.0 - x)
    return start + swing * (shape + wander + dips)


def _measured_nodes(n: np.ndarray, env: np.ndarray, dt: float, active: dict) -> dict[str, np.ndarray]:
    """True temperatures of the three measured nodes: lags of ambient + heat(n), with the effects on."""
    heat = n
    if "nonlinear_speed_heat" in active:
        p, ref = active["nonlinear_speed_heat"].get("exponent"), active["nonlinear_speed_heat"].get("reference_rpm")
        heat = ref * (n / ref) ** p
    slower = 1.0
    if "stop_convection" in active:
        slower = np.where(n < STANDSTILL_RPM, active["stop_convection"].get("factor"), 1.0)
    temps = {}
    for node in NODES:
        rise = node.gain_K_per_rpm * heat
        if node.name == "T_gearbox" and "gear_ratio_switch" in active:
            rise = gear_ratio_switch.twin_heat(rise, n, active["gear_ratio_switch"], dt)
        a = np.exp(-dt / (node.tau_min * 60.0 * slower))
        if node.name == "T_spindle" and "coolant_switching" in active:
            temps[node.name] = _lag_with_coolant(env + rise, a, env[0], active["coolant_switching"], dt)
        else:
            temps[node.name] = _lag(env + rise, a, env[0])
    return temps


def _lag_with_coolant(u: np.ndarray, a, y0: float, coolant, dt: float) -> np.ndarray:
    """The spindle lag with a relay: on above on_C, off below off_C (from the previous sample's true
    temperature); while on it removes cooling_K of steady rise, through the cooling's own lag when it has one."""
    on_C, off_C, cooling = coolant.get("on_C"), coolant.get("off_C"), coolant.get("cooling_K")
    cooling_pole = coolant_switching.twin_pole(coolant, dt)
    a = np.broadcast_to(a, u.shape).tolist()
    y, cooled, share = [y0], False, 0.0
    for k, target in zip(a[1:], u[1:].tolist()):
        last = y[-1]
        cooled = last > on_C or (cooled and last >= off_C)
        share = cooling_pole * share + (1.0 - cooling_pole) * (1.0 if cooled else 0.0)
        y.append(k * last + (1.0 - k) * (target - cooling * share))
    return np.asarray(y)


def _displacement(temps: dict, env: np.ndarray, v: np.ndarray, dt: float, active: dict) -> np.ndarray:
    """E = Σ k_i (T_i − T_i[0]) + k_ram (T_ram − T_ram[0]), plus the lagged terms of the effects switched
    on: a bed node behind the ram, the crossbeam following the hall air, a ball screw heated by the feed."""
    mix = sum(node.ram_weight * temps[node.name] for node in NODES)
    ram = _lag(mix, np.exp(-dt / (RAM_TAU_H * 3600.0)), mix[0])
    e = sum(node.um_per_K * (temps[node.name] - temps[node.name][0]) for node in NODES)
    e = e + RAM_UM_PER_K * (ram - ram[0])
    lagged = {"slow_structure": (ram, ram[0]), "ambient_coupling": (env, env[0]),
              "feed_axis_heat": (FEED_K_PER_MM_MIN * v, 0.0)}
    for name, (x, x0) in lagged.items():
        if name in active:
            a = np.exp(-dt / (active[name].get("tau_h") * 3600.0))
            e = e + active[name].get("um_per_K") * (_lag(x, a, x0) - x0)
    return e


def _apply_sensor_errors(readings: dict, t: np.ndarray, active: dict, faults: tuple) -> None:
    """Offset, drift and faults land on the reading of one column, never on the physics."""
    if "sensor_offset" in active:
        readings[active["sensor_offset"].get("column")] += active["sensor_offset"].get("offset_K")
    if "sensor_drift" in active:
        readings[active["sensor_drift"].get("column")] += active["sensor_drift"].get("rate_K_per_h") * t / 3600.0
    for f in faults:
        readings[f.column] = readings[f.column] + np.asarray(f.error(t), float)
