"""Nonlinear speed heat: heat grows as n^p with p != 1.

Term: the speed heat s(n) becomes n^p through a node table (the block interpolates the same
table); the exponent is searched."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from thermoplc.physics.effects.definition import EffectDefinition
from thermoplc.physics.effects.evidence import speed_groups

MIN_EXPONENT_CHANGE = 0.05  # an exponent within this of 1 is linear heat
RUNNING_RPM = 1.0
TABLE_SEGMENTS = 16  # the n^p table's segments up to 1.25 times the top speed
EXPONENT_RANGE = (0.2, 3.5)


def describe(sim, series) -> dict:
    return {"exponent": sim.shared.exponent, "reference_rpm": sim.shared.reference_rpm}


def draw(rng: np.random.Generator, clean: dict, train: slice, machine) -> dict:
    n = clean["n_rpm"][train]
    return {"exponent": float(rng.uniform(1.3, 2.2)), "reference_rpm": float(np.median(n[n > RUNNING_RPM]))}


def untestable(train) -> str | None:
    groups = speed_groups(train)
    if groups < 3:
        return f"the training part runs at {groups} speed group(s); a curve needs at least three"
    return None


def implausible(sim, train, routines) -> str | None:
    exponent = sim.shared.exponent
    if not 0.25 < exponent < 3.4:
        return f"exponent {exponent:.3g} at the end of the searched range"
    if abs(exponent - 1.0) < MIN_EXPONENT_CHANGE:
        return f"exponent {exponent:.3g}: linear heat"
    return None



def _with_table(speeds: np.ndarray, shared):
    """The table's nodes and reference speed from the running speeds."""
    running = speeds[speeds > shared.stopped_rpm]
    top = float(np.max(running)) if len(running) else 1.0
    return replace(shared, reference_rpm=float(np.median(running)) if len(running) else 1.0,
                   table_rpm=tuple(np.linspace(0.0, 1.25 * top, TABLE_SEGMENTS + 1)))


def search_open_loop(series, shared, effects, starts, routines):
    return routines.simulation.search_shared(series, _with_table(series.n, shared), effects, starts,
                                             "nonlinear_speed_heat", EXPONENT_RANGE,
                                             lambda s, v: replace(s, exponent=float(v)))


def search_identified(runs, shared, effects, sensors, routines):
    from thermoplc.physics.primitives import minimize_scalar
    shared = _with_table(np.concatenate([series.n for series in runs]), shared)
    cost = lambda v: routines.identify.held_cost(runs, replace(shared, exponent=float(v)), effects, sensors)
    return replace(shared, exponent=float(minimize_scalar(cost, bounds=EXPONENT_RANGE, method="bounded",
                                                          options={"xatol": 1e-3}).x))


EFFECT = EffectDefinition(
    name="nonlinear_speed_heat", rank=2, bounds=(("exponent", 0.0, 10.0), ("reference_rpm", 0.0, 100000.0)), description="heat grows as n^p with p != 1",
    defaults=(("exponent", 1.6), ("reference_rpm", 1500.0)), positive=("exponent", "reference_rpm"),
    part="speed", added_parameters=lambda sensors: 1,
    describe=describe, draw=draw, untestable=untestable, implausible=implausible,
    search_open_loop=search_open_loop, search_identified=search_identified)
