"""A campaign of one synthetic machine: N runs with known truth, as a machine-tool builder records them.

The machine (its time constants and gains) is the same in every run; what changes is what changes
on a real shop floor: the hall air (held at a level between 14 and 34 degC, or swinging by 3 K as
an air conditioning that ramps), the speed programme and the noise (the run's seed), and the start
state (cold: settled at the hall air; warm: after two hours of running, cut off). A designed ambient
experiment (`levels`) instead soaks the machine at 20 degC before every run (each starts cold) and moves
the air to the run's set level as it starts (machines/hall.py), the levels taken in turn. The drift is
probed every `probe_minutes` (0: every call) and held between probings, as a probing cycle leaves
it on the NC; the measured target is taken relative to the run's first probing, the true one
beside it on the same zero. Effects of the library can be hidden in all runs or in some.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.machines import hall, machine

WARM_UP_H = 2.0
SWING_K = 3.0
HALL_AIR_C = (14.0, 34.0)
WARM_HALL_C = 25.0  # the runs table's `hall`: cool up to it, warm above (fit on cool days, predict warm ones)
TARGET, TRUTH = "E_z_um", "E_z_true_um"  # both machines' measured and true drift


@dataclass(frozen=True)
class RunPlan:
    """What one run of the campaign is: its attributes in the runs table."""
    index: int
    seed: int
    hall_air_C: float
    air: str  # "held", "swinging", or "stepped" (from hall.REFERENCE_C to hall_air_C as the run starts)
    start: str  # "cold" or "warm"
    effects: tuple = ()

    def attributes(self) -> dict:
        return {"hall_air_C": f"{self.hall_air_C:.1f}", "hall": "warm" if self.hall_air_C > WARM_HALL_C else "cool",
                "air": self.air, "start": self.start, "seed": str(self.seed),
                "effects": "+".join(e.name for e in self.effects) or "none"}


def plan(runs: int, seed: int, effects: tuple = (), effect_runs: tuple[int, ...] | None = None,
         levels: tuple[float, ...] | None = None) -> list[RunPlan]:
    """The runs' conditions, drawn from `seed`: hall air spread over its range (shuffled), every third run
    swinging, every other run warm; or, with `levels`, the air stepped to them in turn; the effects in
    `effect_runs` (numbered from 1; None: every run)."""
    if runs < 1:
        raise UserError("--runs must be at least 1")
    if levels:
        return [replace(run, hall_air_C=float(levels[run.index % len(levels)]), air="stepped", start="cold")
                for run in plan(runs, seed, effects, effect_runs)]
    rng = np.random.default_rng([seed, 37])
    levels = rng.permutation(np.linspace(*HALL_AIR_C, runs)) if runs > 1 else np.array([20.0])
    chosen = set(range(1, runs + 1)) if effect_runs is None else set(effect_runs)
    outside = sorted(k for k in chosen if not 1 <= k <= runs)
    if outside:
        raise UserError(f"--effect-runs: run {outside[0]} is not among the {runs} runs")
    return [RunPlan(k, seed * 1000 + k, float(levels[k]), "swinging" if k % 3 == 2 else "held",
                    "warm" if k % 2 else "cold", effects if k + 1 in chosen else ())
            for k in range(runs)]


def probed(values: np.ndarray, dt: float, probe_minutes: float) -> np.ndarray:
    """The drift as a probing cycle leaves it: measured every `probe_minutes` (the first call included) and
    held until the next probing; every call when 0."""
    if probe_minutes <= 0:
        return values
    step = max(int(round(probe_minutes * 60 / dt)), 1)
    return values[(np.arange(len(values)) // step) * step]


def simulate_run(name: str, run: RunPlan, hours: float, dt: float, probe_minutes: float, noise: float = 1.0) -> dict:
    """One run's columns (the machine's own, with the target probed and held, relative to the first probing)."""
    chosen = machine(name)
    warm = WARM_UP_H if run.start == "warm" else 0.0
    swing = SWING_K if run.air == "swinging" else 0.0
    air = ({"ambient_start": hall.REFERENCE_C, "ambient_level": run.hall_air_C, "ambient_step_s": warm * 3600}
           if run.air == "stepped" else {"ambient_start": run.hall_air_C})
    columns = chosen.simulate(hours + warm, run.seed, dt, ambient_swing=swing, effects=run.effects, noise=noise,
                              **air)
    skip = int(round(warm * 3600 / dt))
    columns = {c: v[skip:].copy() for c, v in columns.items()}
    columns["time_s"] = columns["time_s"] - columns["time_s"][0]
    zero = columns[TARGET][0]
    columns[TARGET] = probed(columns[TARGET] - zero, dt, probe_minutes)
    columns[TRUTH] = columns[TRUTH] - zero
    return columns
