"""The synthetic machine (DESIGN §7): a lumped-mass network whose truth is known.

Nodes: spindle motor, front bearing, ram structure and a slow base structure, exchanging heat
with each other and the ambient air. Motor and bearing heat grow with spindle speed. The
linear network is discretised exactly (matrix exponential, inputs held over a sample), so the
data does not depend on an integrator's step. Displacement at the spindle nose follows the
structure temperatures (time constants of hours) plus a little bearing growth.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from thermoplc.errors import UserError

NODES = ("T_motor", "T_bearing", "T_struct", "T_base")
CAPACITY = np.array([1.0, 1.0, 4.0, 12.0])
# conductances between nodes (same units as CAPACITY per second) and to ambient
LINKS = {(0, 2): 1 / 12000, (1, 2): 1 / 6000, (2, 3): 4 / 20000}
TO_AMBIENT = np.array([1 / 3000, 1 / 2400, 4 / 9000, 12 / 40000])
HEAT_PER_RPM = np.array([1.7e-6, 1.4e-6, 0.0, 0.0])  # motor and bearing heat, per rpm
DISPLACEMENT_UM_PER_K = np.array([0.0, 1.5, 12.0, 6.0])
YAW_URAD_PER_K = np.array([0.0, 3.0, -1.0, 0.0])  # asymmetric heating tilts the spindle (paper 002)
PITCH_URAD_PER_K = np.array([1.5, 0.0, 0.0, -0.8])
TOOL_LENGTHS_MM = (80.0, 150.0, 250.0)
ANGLE_NOISE_URAD = 0.3
TEMP_NOISE_K = 0.05
DISPLACEMENT_NOISE_UM = 0.5
SPEEDS_RPM = (500, 750, 1000, 1300, 1500, 2000, 2500, 3000)
FAULT_KINDS = ("sin", "offset")


@dataclass(frozen=True)
class SensorFault:
    """Paper 000 eq. 18 (`sin`: +2*sin(t/350) °C) or eq. 19 (`offset`: -2 °C) from `start_s` on."""
    kind: str
    column: str
    start_s: float = 0.0

    @staticmethod
    def parse(text: str) -> "SensorFault":
        spec, _, start = text.partition("@")
        kind, _, column = spec.partition(":")
        if kind not in FAULT_KINDS or column not in NODES:
            raise UserError(f"--sensor-fault {text!r}: expected KIND:COLUMN[@START_S] with KIND one of "
                            f"{', '.join(FAULT_KINDS)} and COLUMN one of {', '.join(NODES)}")
        try:
            return SensorFault(kind, column, float(start) if start else 0.0)
        except ValueError:
            raise UserError(f"--sensor-fault {text!r}: start time {start!r} is not a number of seconds") from None

    def error(self, t: np.ndarray) -> np.ndarray:
        active = t >= self.start_s
        wave = 2.0 * np.sin(t / 350.0) if self.kind == "sin" else np.full_like(t, -2.0)
        return np.where(active, wave, 0.0)


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


def _network():
    k = len(NODES)
    m = np.zeros((k, k))
    for (i, j), g in LINKS.items():
        m[i, i] -= g
        m[j, j] -= g
        m[i, j] += g
        m[j, i] += g
    m -= np.diag(TO_AMBIENT)
    drive = np.column_stack([HEAT_PER_RPM, TO_AMBIENT])  # inputs: speed, ambient
    return m / CAPACITY[:, None], drive / CAPACITY[:, None]


def simulate(hours: float, seed: int, dt: float = 10.0, ambient_start: float = 20.0, ambient_swing: float = 0.5,
             faults: tuple[SensorFault, ...] = (), constant_rpm: float | None = None) -> dict:
    """Columns time_s, n_rpm, T_env, the four node sensors, E_z_um (measured), E_z_true_um, the spindle
    tilts yaw_urad and pitch_urad, and the tool length in use, tool_length_mm."""
    if hours <= 0 or dt <= 0:
        raise UserError("--hours and --dt must be positive")
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, hours * 3600 + dt / 2, dt)
    n = speed_schedule(t, rng)
    if constant_rpm is not None:  # paper 000 case 1: one speed from the start
        n = np.full_like(t, constant_rpm)
    te = ambient_profile(t, ambient_start, ambient_swing, rng)
    m, drive = _network()
    k = len(NODES)
    block = np.zeros((k + 2, k + 2))
    block[:k, :k] = m
    block[:k, k:] = drive
    step = expm(block * dt)
    ad, bd = step[:k, :k], step[:k, k:]
    state = np.full(k, te[0])
    temps = np.empty((len(t), k))
    for j in range(len(t)):
        temps[j] = state
        state = ad @ state + bd @ np.array([n[j], te[j]])
    truth = (temps - temps[0]) @ DISPLACEMENT_UM_PER_K
    measured = temps + rng.normal(0, TEMP_NOISE_K, temps.shape)
    for fault in faults:
        measured[:, NODES.index(fault.column)] += fault.error(t)
    columns = {"time_s": t, "n_rpm": n, "T_env": te + rng.normal(0, TEMP_NOISE_K, len(t))}
    columns.update({name: measured[:, i] for i, name in enumerate(NODES)})
    columns["E_z_um"] = truth + rng.normal(0, DISPLACEMENT_NOISE_UM, len(t))
    columns["E_z_true_um"] = truth
    rises = temps - temps[0]
    columns["yaw_urad"] = rises @ YAW_URAD_PER_K + rng.normal(0, ANGLE_NOISE_URAD, len(t))
    columns["pitch_urad"] = rises @ PITCH_URAD_PER_K + rng.normal(0, ANGLE_NOISE_URAD, len(t))
    columns["tool_length_mm"] = np.array(TOOL_LENGTHS_MM)[(t // (4 * 3600)).astype(int) % len(TOOL_LENGTHS_MM)]
    return columns
