"""The synthetic machine (docs/diagnosis.md): a lumped-mass network whose truth is known.

Nodes: spindle motor and front bearing (heated by the spindle speed, cooled to ambient, each a
first-order lumped mass as in paper 000 eq. 4), the ram structure (fed by the motor and bearing
temperatures, exchanging heat with the air only through them), a slow base structure below the
ram, and a feed-axis ball screw heated by axis motion. The network is linear and discretised
exactly (matrix exponential, inputs held over a sample), so the data does not depend on an
integrator's step. The displacement at the spindle nose follows the temperature rises of the
bearing and the ram, the ambient-driven part included: without an effect the machine is inside
paper 000's class (first-order sensors, displacement linear in their temperatures and a structure
lagging them). Each named effect of `thermoplc.physics.effects` can be switched on.
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import expm

from thermoplc.base.errors import UserError
from thermoplc.machines import hall
from thermoplc.machines.faults import SensorFault
from thermoplc.physics.effects import Effect, coolant_switching, gear_ratio_switch

NAME = "cascade"
DESCRIPTION = "motor and bearing nodes feeding a ram and a slow base, run/stop at fixed speed levels, daily sine ambient"
NODES = ("T_motor", "T_bearing", "T_struct", "T_base")  # the sensor columns
SENSORS = NODES
DIAGNOSED = ("T_motor", "T_bearing")  # what a diagnosis is given: the ram and base are not measured
COOLANT_SENSOR = "T_motor"  # the relay of coolant_switching reads this node
COLUMN_DEFAULTS = {"sensor_offset": "T_bearing", "sensor_drift": "T_motor"}
TAU_S = {"motor": 2400.0, "bearing": 1800.0, "struct": 9000.0, "screw": 1800.0}
RISE_AT_3000_RPM_K = {"motor": 12.0, "bearing": 8.0}
STRUCT_FROM = {"motor": 0.4, "bearing": 0.6}  # the ram settles at this mix of the motor and bearing temperatures
SCREW_K_PER_MM_MIN = 1.0 / 1000.0  # ball screw rise per feed rate at steady state
DISPLACEMENT_UM_PER_K = {"bearing": 1.5, "struct": 5.0}
YAW_URAD_PER_K = np.array([0.0, 3.0, -1.0, 0.0])  # asymmetric heating tilts the spindle (paper 002)
PITCH_URAD_PER_K = np.array([1.5, 0.0, 0.0, -0.8])
TOOL_LENGTHS_MM = (80.0, 150.0, 250.0)
ANGLE_NOISE_URAD = 0.3
TEMP_NOISE_K = 0.05
DISPLACEMENT_NOISE_UM = 0.5
SPEEDS_RPM = (500, 750, 1000, 1300, 1500, 2000, 2500, 3000)
FEEDS_MM_MIN = (0, 500, 2000, 4000, 6000)
STOPPED_RPM = 0.5


def speed_schedule(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Run/stop steps: a 10 min stop, then runs of 1-4 h at a random speed and stops of 0.5-3 h."""
    n = np.zeros_like(t)
    start = 600.0
    while start < t[-1]:
        run = rng.uniform(1, 4) * 3600
        n[(t >= start) & (t < start + run)] = rng.choice(SPEEDS_RPM)
        start += run + rng.uniform(0.5, 3) * 3600
    return n


def ambient_profile(t: np.ndarray, start_c: float, swing_k: float, rng: np.random.Generator) -> np.ndarray:
    """Starts at `start_c`; a daily sine of amplitude `swing_k` peaking mid-afternoon, plus a slow wander."""
    phase = -2 * np.pi * 10 / 24
    daily = swing_k * (np.sin(2 * np.pi * t / 86400 + phase) - np.sin(phase))
    wander = np.cumsum(rng.normal(0, 0.002, len(t)))
    return start_c + daily + wander - wander[0]


def feed_schedule(n: np.ndarray, dt: float, rng: np.random.Generator) -> np.ndarray:
    """Feed-axis rate, mm/min: while the spindle runs, blocks of 10-40 min at a random feed; 0 at standstill."""
    v = np.zeros_like(n)
    j = 0
    while j < len(n):
        length = max(1, int(rng.uniform(600, 2400) / dt))
        v[j:j + length] = rng.choice(FEEDS_MM_MIN)
        j += length
    return np.where(n > STOPPED_RPM, v, 0.0)


def _step_matrices(dt: float, tau: dict, tau_base: float):
    """Exact discretisation of the network; state (motor, bearing, struct, base, screw), inputs
    (motor heat, bearing heat, screw heat in K/s, ambient)."""
    m = np.zeros((5, 5))
    drive = np.zeros((5, 4))
    for i, node in ((0, "motor"), (1, "bearing"), (4, "screw")):
        m[i, i] = -1 / tau[node]
        drive[i, 3] = 1 / tau[node]
    drive[0, 0] = drive[1, 1] = drive[4, 2] = 1.0
    m[2, 2] = -1 / tau["struct"]
    m[2, 0] = STRUCT_FROM["motor"] / tau["struct"]
    m[2, 1] = STRUCT_FROM["bearing"] / tau["struct"]
    m[3, 3] = -1 / tau_base
    m[3, 2] = 1 / tau_base
    block = np.zeros((9, 9))
    block[:5, :5] = m
    block[:5, 5:] = drive
    step = expm(block * dt)
    return step[:5, :5], step[:5, 5:]


def _lag(u: np.ndarray, tau: float, dt: float) -> np.ndarray:
    """First-order lag with the input held over a sample, starting settled at u[0]."""
    a = np.exp(-dt / tau)
    out = np.empty_like(u)
    y = u[0]
    for j, x in enumerate(u):
        y = a * y + (1 - a) * x
        out[j] = y
    return out


def simulate(hours: float, seed: int, dt: float = 10.0, ambient_start: float = 20.0, ambient_swing: float = 0.5,
             faults: tuple[SensorFault, ...] = (), constant_rpm: float | None = None,
             effects: tuple[Effect, ...] = (), noise: float = 1.0, ambient_level: float | None = None,
             ambient_step_s: float = 0.0) -> dict:
    """Columns time_s, n_rpm, v_feed_mm_min, T_env, the four node sensors, E_z_um (measured),
    E_z_true_um, the spindle tilts yaw_urad and pitch_urad, and the tool length in use; with
    `ambient_level` the hall air moves to it from `ambient_step_s` on (machines/hall.py)."""
    if hours <= 0 or dt <= 0:
        raise UserError("--hours and --dt must be positive")
    if noise < 0:
        raise UserError("--noise must be zero or positive")
    on = {e.name: e for e in effects}
    for e in effects:
        if e.name in COLUMN_DEFAULTS and e.get("column") not in NODES:
            raise UserError(f"--effect {e.name}: column must be one of {', '.join(NODES)}, found {e.get('column')!r}")
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, hours * 3600 + dt / 2, dt)
    n = speed_schedule(t, rng)
    if constant_rpm is not None:  # paper 000 case 1: one speed from the start
        n = np.full_like(t, constant_rpm)
    te = ambient_profile(t, ambient_start, ambient_swing, rng)
    if ambient_level is not None:
        te = hall.stepped(t, te, ambient_level, ambient_step_s)
    feed = feed_schedule(n, dt, np.random.default_rng([seed, 1]))

    tau = dict(TAU_S)
    if "feed_axis_heat" in on:
        tau["screw"] = on["feed_axis_heat"].get("tau_h") * 3600
    tau_base = on["slow_structure"].get("tau_h") * 3600 if "slow_structure" in on else 8 * 3600.0
    running = _step_matrices(dt, tau, tau_base)
    stopped = running
    if "stop_convection" in on:
        factor = on["stop_convection"].get("factor")
        stopped = _step_matrices(dt, {**tau, "motor": tau["motor"] * factor, "bearing": tau["bearing"] * factor},
                                 tau_base)

    speed_heat = n.copy()
    if "nonlinear_speed_heat" in on:
        e = on["nonlinear_speed_heat"]
        speed_heat = e.get("reference_rpm") * (n / e.get("reference_rpm")) ** e.get("exponent")
    motor_heat = RISE_AT_3000_RPM_K["motor"] / (TAU_S["motor"] * 3000) * speed_heat
    if "gear_ratio_switch" in on:
        motor_heat = gear_ratio_switch.twin_heat(motor_heat, n, on["gear_ratio_switch"], dt)
    bearing_heat = RISE_AT_3000_RPM_K["bearing"] / (TAU_S["bearing"] * 3000) * speed_heat
    screw_heat = SCREW_K_PER_MM_MIN / tau["screw"] * feed
    coolant = on.get("coolant_switching")

    full = np.empty((len(t), 5))
    ambient_only = np.empty((len(t), 5))
    state = np.full(5, te[0])
    still = np.full(5, te[0])
    cooling, share = False, 0.0
    cooling_pole = 0.0 if coolant is None else coolant_switching.twin_pole(coolant, dt)
    for j in range(len(t)):
        ad, bd = stopped if n[j] <= STOPPED_RPM else running
        q_motor = motor_heat[j]
        if coolant is not None:
            if state[0] > coolant.get("on_C"):
                cooling = True
            elif state[0] < coolant.get("off_C"):
                cooling = False
            share = cooling_pole * share + (1.0 - cooling_pole) * (1.0 if cooling else 0.0)  # its own lag (0: at once)
            q_motor -= coolant.get("cooling_K") * share / tau["motor"]
        state = ad @ state + bd @ np.array([q_motor, bearing_heat[j], screw_heat[j], te[j]])
        still = ad @ still + bd @ np.array([0.0, 0.0, 0.0, te[j]])
        full[j] = state
        ambient_only[j] = still
    heat = full - ambient_only
    rise = full - te[0]  # the network starts settled at the first ambient
    truth = DISPLACEMENT_UM_PER_K["bearing"] * rise[:, 1] + DISPLACEMENT_UM_PER_K["struct"] * rise[:, 2]
    if "slow_structure" in on:
        truth = truth + on["slow_structure"].get("um_per_K") * rise[:, 3]
    if "feed_axis_heat" in on:
        truth = truth + on["feed_axis_heat"].get("um_per_K") * heat[:, 4]
    if "ambient_coupling" in on:
        e = on["ambient_coupling"]
        truth = truth + e.get("um_per_K") * (_lag(te, e.get("tau_h") * 3600, dt) - te[0])

    temps = full[:, :4]
    measured = temps + rng.normal(0, TEMP_NOISE_K * noise, temps.shape)
    for fault in faults:
        measured[:, NODES.index(fault.column)] += fault.error(t)
    if "sensor_offset" in on:
        measured[:, NODES.index(on["sensor_offset"].get("column"))] += on["sensor_offset"].get("offset_K")
    if "sensor_drift" in on:
        measured[:, NODES.index(on["sensor_drift"].get("column"))] += on["sensor_drift"].get("rate_K_per_h") * t / 3600
    columns = {"time_s": t, "n_rpm": n, "v_feed_mm_min": feed,
               "T_env": te + rng.normal(0, TEMP_NOISE_K * noise, len(t))}
    columns.update({name: measured[:, i] for i, name in enumerate(NODES)})
    columns["E_z_um"] = truth + rng.normal(0, DISPLACEMENT_NOISE_UM * noise, len(t))
    columns["E_z_true_um"] = truth
    rises = heat[:, :4]
    columns["yaw_urad"] = rises @ YAW_URAD_PER_K + rng.normal(0, ANGLE_NOISE_URAD * noise, len(t))
    columns["pitch_urad"] = rises @ PITCH_URAD_PER_K + rng.normal(0, ANGLE_NOISE_URAD * noise, len(t))
    columns["tool_length_mm"] = np.array(TOOL_LENGTHS_MM)[(t // (4 * 3600)).astype(int) % len(TOOL_LENGTHS_MM)]
    return columns
