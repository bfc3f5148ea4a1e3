"""Coolant switching: extra cooling switched on and off at temperature thresholds (hysteresis).

Term: one more heat input per sensor, `cooling * state`, the relay switched by the simulated
temperature of one sensor (tried on each); the thresholds are searched."""
from __future__ import annotations

import numpy as np

from thermoplc.physics.effects.definition import EffectDefinition

MIN_RELAY_SWITCHES = 3  # on, off, on: one cycle and the start of another


def check(parameters: dict) -> str | None:
    if not parameters["on_C"] > parameters["off_C"]:
        return (f"on_C ({parameters['on_C']:g}) must be above off_C ({parameters['off_C']:g}): "
                "the relay's hysteresis")
    return None


def describe(sim, series) -> dict:
    s = sim.shared
    return {"switch_sensor": series.names[s.relay[0]], "on_C": s.relay[1], "off_C": s.relay[2],
            "cooling_K": {c: p.cooling for c, p in zip(series.names, sim.sensors)}}


def draw(rng: np.random.Generator, clean: dict, train: slice, machine) -> dict:
    """On between the 55th and 80th percentile of the switch sensor's training temperatures, off
    1.5-4 K below: the relay switches several times; cooling 2-6 K of steady rise."""
    t = clean[machine.COOLANT_SENSOR][train]
    on = float(np.quantile(t, rng.uniform(0.55, 0.8)))
    gap = min(rng.uniform(1.5, 4.0), 0.8 * (on - float(np.quantile(t, 0.1))))
    return {"on_C": on, "off_C": on - max(gap, 0.5), "cooling_K": float(rng.uniform(2.0, 6.0))}


def implausible(sim, train) -> str | None:
    if sim.sensors[sim.shared.relay[0]].cooling >= 0:
        return "the switched term heats the sensor that switches it"
    return None


def too_quiet(sim, train) -> str | None:
    """A fitted coolant relay that switches too rarely in training is a step, not a coolant."""
    from thermoplc.physics.simulation import closed_loop_cooling
    state = closed_loop_cooling(train, sim.shared, sim.sensors, sim.effects)
    switches = int(np.count_nonzero(np.diff(np.r_[0.0, state])))
    if switches < MIN_RELAY_SWITCHES:
        return (f"the fitted relay switches {switches} time(s) in the training part; at least {MIN_RELAY_SWITCHES} "
                f"are needed to tell a coolant from a one-off change")
    return None


EFFECT = EffectDefinition(
    name="coolant_switching", rank=1, bounds=(("on_C", -50.0, 250.0), ("off_C", -50.0, 250.0), ("cooling_K", -100.0, 100.0)),
    description="extra motor cooling switched on/off at temperature thresholds with hysteresis",
    defaults=(("on_C", 27.0), ("off_C", 24.0), ("cooling_K", 4.0)), check=check,
    part="heat", per_sensor=True, added_parameters=lambda sensors: sensors + 2,
    describe=describe, draw=draw, implausible=implausible, after_fit=too_quiet)
