"""Ambient coupling: the structure follows ambient swings (day and night) through a lag of its own.

Term: one more displacement column, a lag of the ambient from its first value, with one weight."""
from __future__ import annotations

import numpy as np

from thermoplc.physics.effects.definition import DisplacementTerm, EffectDefinition
from thermoplc.physics.effects.evidence import HOUR, shorter_than_a_day, time_constant_at_bound


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


def implausible(sim, train) -> str | None:
    return time_constant_at_bound(sim.displacement.tau_ambient_s, 650.0, 45 * HOUR)


EFFECT = EffectDefinition(
    name="ambient_coupling", rank=4, bounds=(("tau_h", 0.0, 1000.0), ("um_per_K", -10000.0, 10000.0)), description="the structure follows ambient swings (day/night)",
    defaults=(("tau_h", 3.0), ("um_per_K", 10.0)), positive=("tau_h",),
    part="displacement", added_parameters=lambda sensors: 2,
    displacement=DisplacementTerm("ambient", "tau_ambient_s", "alpha", per_sensor=False, search_s=(600.0, 48 * HOUR),
                                  columns=columns, pole=("AAm", "BAm"), weight="alpha"),
    describe=describe, draw=draw, untestable=shorter_than_a_day, implausible=implausible)
