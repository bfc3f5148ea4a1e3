"""Slow structure: a second, slow thermal time constant in the displacement.

Term: per sensor one more displacement column, a slow lag of the structure's lag (or of the
temperature when the model has no structure lag), with its own weight; the time constant is
searched at least 1.5 times the structure's."""
from __future__ import annotations

import numpy as np

from thermoplc.physics.effects.definition import DisplacementTerm, EffectDefinition
from thermoplc.physics.effects.evidence import HOUR, shorter_than_a_day, time_constant_at_bound

MIN_HEAT_KEPT_SHARE = 0.5  # a slow structure must keep at least half as much of the heat as of the ambient
REFERENCE_S = 1200.0  # without a structure lag the slow lag must exceed a multiple of this
MIN_RATIO = 1.5


def reference_s(tau_struct_s: float | None) -> float:
    """What the slow time constant must exceed a multiple of: the structure's, so the two cannot swap roles."""
    return tau_struct_s if tau_struct_s is not None else REFERENCE_S


def columns(series, temps, lagged, t0, tau_s: float) -> list:
    """Per sensor a slow lag of the structure's lag (or of the temperature), from its start."""
    from thermoplc.physics.primitives import lag_columns, pole
    slow = lag_columns(lagged, pole(tau_s, series.dt), t0)
    return [slow[:, i] - t0[i] for i in range(temps.shape[1])]


def describe(sim, series) -> dict:
    d = sim.displacement
    return {"tau_h": d.tau_slow_s / HOUR, "um_per_K": dict(zip(series.names, d.delta))}


def draw(rng: np.random.Generator, clean: dict, train: slice, machine) -> dict:
    return {"tau_h": float(rng.uniform(2.0, 12.0)), "um_per_K": float(rng.uniform(5.0, 25.0))}


def kept_shares(sim, train, routines) -> tuple[float, float]:
    """How much of the machine's heat and of the ambient the fitted slow structure keeps: the RMS of
    its weighted sum over the RMS of the same sum with every weight made positive (1 when the
    sensors add up, near 0 when their weights cancel), for each part of the temperatures."""
    ambient, heat, start = routines.simulation.ambient_and_heat_parts(train, sim)
    weights = np.asarray(sim.displacement.delta)
    shares = []
    for part, origin in ((heat, np.zeros_like(start)), (ambient, start)):
        terms = routines.displacement.term_columns(train, sim, "slow_structure", part, origin)
        whole = float(np.std(terms @ np.abs(weights)))
        shares.append(float(np.std(terms @ weights)) / whole if whole > 0 else 1.0)
    return shares[0], shares[1]


def lag_of_the_air(sim, train, routines) -> str | None:
    """Why a fitted slow structure is a lag of the hall air rather than a structure the machine heats
    (which follows that heat), or None."""
    heat_kept, ambient_kept = kept_shares(sim, train, routines)
    if heat_kept < MIN_HEAT_KEPT_SHARE * ambient_kept:
        return (f"its weights keep {heat_kept:.0%} of the machine's heat between the sensors and {ambient_kept:.0%} "
                "of the ambient: a lag of the air, not a structure the machine heats")
    return None


def implausible(sim, train, routines) -> str | None:
    # the slow lag's lower limit relative to the structure's only keeps the two apart; a fit that
    # rests on it is a second structure time constant close to the first, still the named physics
    return lag_of_the_air(sim, train, routines) or time_constant_at_bound(sim.displacement.tau_slow_s, 1900.0, 90 * HOUR)


def alike_after(before, trial, train, routines) -> tuple[tuple[str, ...], str] | None:
    """After an ambient lag was added, a slow structure whose weights cancel the heat is the same lag
    of the air again."""
    if before.has("ambient_coupling") and lag_of_the_air(trial, train, routines):
        return ("ambient_coupling", "slow_structure"), (
            "after the ambient lag was added, a slow structure whose weights cancel the heat still "
            "improves the fit: the two are not told apart")
    return None


EFFECT = EffectDefinition(
    name="slow_structure", rank=3, bounds=(("tau_h", 0.0, 1000.0), ("um_per_K", -10000.0, 10000.0)), description="a second, slow thermal time constant in the displacement",
    defaults=(("tau_h", 16.0), ("um_per_K", 20.0)), positive=("tau_h",),
    part="displacement", added_parameters=lambda sensors: 1 + sensors,
    displacement=DisplacementTerm("slow", "tau_slow_s", "delta", per_sensor=True, search_s=(1800.0, 96 * HOUR),
                                  columns=columns, pole=("A2", "B2"), weight="delta",
                                  lowest_s=lambda tau_struct_s: MIN_RATIO * reference_s(tau_struct_s)),
    describe=describe, draw=draw, untestable=shorter_than_a_day, implausible=implausible,
    alike_after=alike_after)
