"""Stop convection: cooling differs when the spindle stands (natural against forced convection).

Term: each sensor's time constant is multiplied by its own factor while the speed is at or below
the standstill threshold."""
from __future__ import annotations

import numpy as np

from thermoplc.physics.effects.definition import EffectDefinition
from thermoplc.physics.effects.evidence import standstills

MIN_LOG_STOP_FACTOR = 0.05  # a standstill factor within 5 % of 1 is no effect
MIN_STANDSTILLS = 2  # stretches at rest of at least STANDSTILL_S, each after running
STANDSTILL_S = 1800.0


def describe(sim, series) -> dict:
    return {"tau_factor_at_standstill": {c: p.stop_factor for c, p in zip(series.names, sim.sensors)},
            "standstill_below_rpm": sim.shared.stopped_rpm}


def draw(rng: np.random.Generator, clean: dict, train: slice, machine) -> dict:
    return {"factor": float(rng.uniform(1.8, 4.0))}


def untestable(train) -> str | None:
    if standstills(train, STANDSTILL_S) < MIN_STANDSTILLS:
        return (f"the training part has fewer than {MIN_STANDSTILLS} standstills of {STANDSTILL_S / 60:g} min "
                f"after running")
    return None


def implausible(sim, train, routines) -> str | None:
    if any(not 0.09 < p.stop_factor < 11.0 for p in sim.sensors):
        return "standstill time-constant factor at the end of the searched range"
    faster = [f"{p.stop_factor:.3g}" for p in sim.sensors if np.log(p.stop_factor) < -MIN_LOG_STOP_FACTOR]
    if faster:  # the named physics: the forced convection of the turning spindle stops, natural convection is weaker
        return (f"standstill time-constant factor {', '.join(faster)}: a sensor cools faster with the spindle still, "
                f"not the weaker natural convection of a machine at rest")
    if all(abs(np.log(p.stop_factor)) < MIN_LOG_STOP_FACTOR for p in sim.sensors):
        return "standstill time constants equal to the running ones: no change"
    return None


EFFECT = EffectDefinition(
    name="stop_convection", rank=8, bounds=(("factor", 0.0, 100.0),),
    description="cooling differs when the spindle stands (natural vs forced convection)",
    defaults=(("factor", 2.5),), positive=("factor",),
    part="pole", added_parameters=lambda sensors: sensors,
    describe=describe, draw=draw, untestable=untestable, implausible=implausible)
