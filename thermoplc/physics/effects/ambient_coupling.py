"""Ambient coupling: the structure follows ambient swings (day and night) through a lag of its own.

Term: one more displacement column, a lag of the ambient from its first value, with one weight."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from thermoplc.physics.effects.definition import DisplacementTerm, EffectDefinition
from thermoplc.physics.effects.evidence import HOUR, ambient_unseen, time_constant_at_bound


def columns(series, temps, lagged, t0, tau_s: float) -> list:
    """A lag of the ambient from its first value."""
    from thermoplc.physics.primitives import lag, pole
    return [lag(series.te, pole(tau_s, series.dt), series.te[0]) - series.te[0]]


def describe(sim, series) -> dict:
    d = sim.displacement
    return {"tau_h": d.tau_ambient_s / HOUR, "um_per_K": d.alpha}


def draw(rng: np.random.Generator, clean: dict, train: slice, machine) -> dict:
    return {"tau_h": float(rng.uniform(1.0, 8.0)),
            "um_per_K": float(rng.choice([-1.0, 1.0]) * rng.uniform(5.0, 15.0))}


def implausible(sim, train, routines) -> str | None:
    """An ambient lag at its search bound, or no slower than a sensor's own lag: the sensors read the air through
    their lags already, and the baseline weighs them (a fast lag of the air is inside its class)."""
    tau_s = sim.displacement.tau_ambient_s
    slowest = max(sensor.tau_s for sensor in sim.sensors)
    if tau_s <= slowest:
        return (f"time constant {tau_s / HOUR:.3g} h, no slower than the sensors' own lag ({slowest / HOUR:.3g} h): "
                f"the sensors' readings of the air carry it")
    return time_constant_at_bound(tau_s, 650.0, 45 * HOUR)


def slower_structure(before, trial):
    """The baseline with its structure lag as slow as the fitted ambient lag: in runs shorter than that lag settles
    thrice, forward validation could not choose it, and a structure that lags the sensors by hours follows the
    air they read by hours too (a designed ambient experiment shows little else)."""
    struct_s, tau_s = before.displacement.tau_struct_s, trial.displacement.tau_ambient_s
    if struct_s is None or tau_s <= struct_s:
        return None
    return (f"a structure lag of {tau_s / HOUR:.3g} h (the baseline's {struct_s / HOUR:.3g} h)",
            replace(before, displacement=replace(before.displacement, tau_struct_s=tau_s, tau_struct_chosen_s=tau_s)))


EFFECT = EffectDefinition(
    name="ambient_coupling", rank=4, bounds=(("tau_h", 0.0, 1000.0), ("um_per_K", -10000.0, 10000.0)), description="the structure follows ambient swings (day/night)",
    defaults=(("tau_h", 3.0), ("um_per_K", 10.0)), positive=("tau_h",),
    part="displacement", added_parameters=lambda sensors: 2,
    displacement=DisplacementTerm("ambient", "tau_ambient_s", "alpha", per_sensor=False, search_s=(600.0, 48 * HOUR),
                                  columns=columns, pole=("AAm", "BAm"), weight="alpha"),
    describe=describe, draw=draw, untestable=ambient_unseen, implausible=implausible,
    rival=slower_structure)
