"""Gear ratio switch: the heat per rpm changes above a speed threshold (paper 000's 750 rpm gearbox).

Term: one more heat input per sensor, `gear_gain * n` while n is above the threshold, through a lag of
its own (a gearbox heats its oil and housing before the heat reaches a sensor; 0 when it enters at once);
the threshold is searched among the speed groups the training part runs, then the lag on a bounded grid."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from thermoplc.physics.effects.definition import EffectDefinition
from thermoplc.physics.effects.evidence import speed_groups

MIN_GEAR_CHANGE = 0.05  # heat ratios above the threshold within 5 % of 1 on every sensor are no switch
RUNNING_RPM = 1.0
LAG_GRID_S = (0.0, 300.0, 600.0, 1200.0, 2400.0, 4800.0, 9600.0)  # the heat's own lag: none, then 5 min .. 2.7 h


def describe(sim, series) -> dict:
    from thermoplc.physics.primitives import speed_levels
    s = sim.shared
    levels = speed_levels(series.n, s)
    above = levels[levels > s.gear_rpm]
    return {"threshold_rpm": s.gear_rpm, "lag_min": s.gear_tau_s / 60.0,
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


def twin_heat(heat: np.ndarray, n: np.ndarray, effect, dt: float) -> np.ndarray:
    """A synthetic machine's heat with this effect on: `ratio` times `heat` above the threshold, the extra part
    through a lag of `lag_min` (a gearbox's oil and housing) when given."""
    from thermoplc.physics.primitives import lag, pole
    above, lag_s = n > effect.get("threshold_rpm"), effect.get("lag_min") * 60.0
    if lag_s == 0:
        return np.where(above, effect.get("ratio") * heat, heat)
    return heat + lag(np.where(above, (effect.get("ratio") - 1.0) * heat, 0.0), pole(lag_s, dt), 0.0)


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


def implausible(sim, train, routines) -> str | None:
    if any(p.gain + p.gear_gain < 0 for p in sim.sensors):
        return "negative heat above the threshold"
    largest_gain = max(abs(p.gain) for p in sim.sensors)
    if all(abs(p.gear_gain) < MIN_GEAR_CHANGE * largest_gain for p in sim.sensors):
        return f"heat per rpm above the threshold within {MIN_GEAR_CHANGE:.0%} of below it: no switch"
    lowered = [name for name, p in zip(train.names, sim.sensors) if _takes_heat_away(p.gain, p.gear_gain)]
    if sim.shared.gear_tau_s > 0 and lowered:  # the search lags none such; a warm refit may turn a lagged one's sign
        return (f"less heat per rpm above the threshold at {', '.join(lowered)}, reaching it through a lag of its own "
                f"({sim.shared.gear_tau_s / 60:.0f} min): less of the same heat takes the path the rest of it takes, so "
                f"a lag of its own is that sensor's second time constant, not a switch")
    return None



def heat_input(series, shared, state) -> tuple[str, np.ndarray]:
    """The heat per rpm above the threshold, through its own lag from zero (the block's LG starts at 0)."""
    from thermoplc.physics.primitives import lag, pole
    above = np.where(series.n > shared.gear_rpm, series.n, 0.0)
    return "gear_gain", lag(above, pole(shared.gear_tau_s, series.dt), 0.0) if shared.gear_tau_s > 0 else above


def _with_lag(shared, tau_s):
    return replace(shared, gear_tau_s=float(tau_s))


def _takes_heat_away(gain: float, gear_gain: float) -> bool:
    """Whether a sensor's heat per rpm above the threshold is below its heat per rpm below it."""
    return bool(gain) and gear_gain / gain < -MIN_GEAR_CHANGE


def search_open_loop(series, shared, effects, starts, routines):
    """The threshold at the top of one of the speed groups below the highest (none with one group), then the
    heat's own lag on LAG_GRID_S with that threshold, unless the switch at once takes heat away (`implausible`)."""
    from thermoplc.physics.primitives import speed_levels
    simulation = routines.simulation
    levels = speed_levels(series.n, shared)
    if len(levels) < 2:
        return replace(shared, gear_rpm=0.0, gear_tau_s=0.0)
    shared = simulation.search_shared(series, _with_lag(shared, 0.0), effects, starts, "gear_ratio_switch",
                                      list(levels[:-1]), lambda s, v: replace(s, gear_rpm=float(v)))
    held = starts or simulation.fit_all_sensors(series, shared, effects, None)[0]
    if any(_takes_heat_away(p.gain, p.gear_gain) for p in simulation.held_sensors(series, shared, effects, held)):
        return shared
    return simulation.search_shared(series, shared, effects, starts, "gear_ratio_switch", list(LAG_GRID_S), _with_lag)


def search_identified(runs, shared, effects, sensors, routines):
    """As `search_open_loop`, by the identified sensors' one-step prediction error."""
    from thermoplc.physics.primitives import speed_levels
    identify = routines.identify
    levels = speed_levels(np.concatenate([series.n for series in runs]), shared)
    if len(levels) < 2:
        return replace(shared, gear_rpm=0.0, gear_tau_s=0.0)
    cost = lambda s: identify.held_cost(runs, s, effects, sensors)
    shared = min((replace(shared, gear_rpm=float(v), gear_tau_s=0.0) for v in levels[:-1]), key=cost)
    at_once = identify.held_heat_gains(runs, shared, effects, sensors)
    if any(_takes_heat_away(g["gain"], g["gear_gain"]) for g in at_once):
        return shared
    return min((_with_lag(shared, tau) for tau in LAG_GRID_S), key=cost)


EFFECT = EffectDefinition(
    name="gear_ratio_switch", rank=0,
    bounds=(("threshold_rpm", 0.0, 100000.0), ("ratio", 0.0, 100.0), ("lag_min", 0.0, 600.0)),
    description="motor heat per rpm changes above a speed threshold (paper 000's 750 rpm gearbox), through a lag "
                "of its own (lag_min, 0: at once)",
    defaults=(("threshold_rpm", 750.0), ("ratio", 1.6), ("lag_min", 0.0)), positive=("ratio",),
    part="heat", added_parameters=lambda sensors: sensors + 2,
    describe=describe, draw=draw, untestable=untestable, look_alike=look_alike, implausible=implausible,
    heat_input=heat_input, search_open_loop=search_open_loop, search_identified=search_identified)
