"""Gear ratio switch: the heat per rpm changes above a speed threshold (paper 000's 750 rpm gearbox).

Term: one more heat input per sensor, `gear_gain * n` while n is above the threshold; the
threshold is searched among the speed groups the training part runs."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from thermoplc.physics.effects.definition import EffectDefinition
from thermoplc.physics.effects.evidence import speed_groups

MIN_GEAR_CHANGE = 0.05  # heat ratios above the threshold within 5 % of 1 on every sensor are no switch
RUNNING_RPM = 1.0


def describe(sim, series) -> dict:
    from thermoplc.physics.primitives import speed_levels
    s = sim.shared
    levels = speed_levels(series.n, s)
    above = levels[levels > s.gear_rpm]
    return {"threshold_rpm": s.gear_rpm,
            "next_speed_rpm": float(above[0]) if len(above) else None,
            "heat_ratio_above": {c: 1.0 + p.gear_gain / p.gain if p.gain else None
                                 for c, p in zip(series.names, sim.sensors)}}


def draw(rng: np.random.Generator, clean: dict, train: slice, machine) -> dict:
    """A threshold between two speeds the machine runs at in training (both sides occupied)."""
    n = clean["n_rpm"][train]
    levels = np.unique(np.round(n[n > RUNNING_RPM], -1))
    low, high = np.quantile(levels, [0.25, 0.75]) if len(levels) > 2 else (levels.min(), levels.max())
    inside = levels[(levels >= low) & (levels <= high)]
    below = rng.choice(inside[:-1]) if len(inside) > 1 else levels[0]
    above = levels[levels > below][0]
    return {"threshold_rpm": float(below + rng.uniform(0.2, 0.8) * (above - below)),
            "ratio": float(rng.uniform(1.3, 3.0))}


def untestable(train) -> str | None:
    groups = speed_groups(train)
    if groups < 2:
        return f"the training part runs at {groups} speed group(s); a threshold needs speeds on both sides"
    return None


def look_alike(train) -> tuple[str, str] | None:
    """Through two speed groups and standstill any heat curve is a switch between them."""
    groups = speed_groups(train)
    if groups < 3:
        return "nonlinear_speed_heat", (f"a switch fits, but the training part runs at {groups} speed groups: a "
                                        "switch between them and a curve through them fit alike, and a curve "
                                        "is tested only from three groups")
    return None


def implausible(sim, train) -> str | None:
    if any(p.gain + p.gear_gain < 0 for p in sim.sensors):
        return "negative heat above the threshold"
    largest_gain = max(abs(p.gain) for p in sim.sensors)
    if all(abs(p.gear_gain) < MIN_GEAR_CHANGE * largest_gain for p in sim.sensors):
        return f"heat per rpm above the threshold within {MIN_GEAR_CHANGE:.0%} of below it: no switch"
    return None



def heat_input(series, shared, state) -> tuple[str, np.ndarray]:
    """The heat per rpm above the threshold."""
    return "gear_gain", np.where(series.n > shared.gear_rpm, series.n, 0.0)


def search_open_loop(series, shared, effects, starts):
    """The threshold at the top of one of the speed groups below the highest (none with one group)."""
    from thermoplc.physics import simulation
    from thermoplc.physics.primitives import speed_levels
    levels = speed_levels(series.n, shared)
    if len(levels) > 1:
        return simulation.search_shared(series, shared, effects, starts, "gear_ratio_switch", list(levels[:-1]),
                                        lambda s, v: replace(s, gear_rpm=float(v)))
    return replace(shared, gear_rpm=0.0)


def search_identified(runs, shared, effects, sensors):
    from thermoplc.physics import identify
    from thermoplc.physics.primitives import speed_levels
    levels = speed_levels(np.concatenate([series.n for series in runs]), shared)
    return (replace(shared, gear_rpm=float(min(levels[:-1], key=lambda v: identify.held_cost(
        runs, replace(shared, gear_rpm=float(v)), effects, sensors)))) if len(levels) > 1
        else replace(shared, gear_rpm=0.0))


EFFECT = EffectDefinition(
    name="gear_ratio_switch", rank=0, bounds=(("threshold_rpm", 0.0, 100000.0), ("ratio", 0.0, 100.0)),
    description="motor heat per rpm changes above a speed threshold (paper 000's 750 rpm gearbox)",
    defaults=(("threshold_rpm", 750.0), ("ratio", 1.6)), positive=("ratio",),
    part="heat", added_parameters=lambda sensors: sensors + 1,
    describe=describe, draw=draw, untestable=untestable, look_alike=look_alike, implausible=implausible,
    heat_input=heat_input, search_open_loop=search_open_loop, search_identified=search_identified)
