"""Feed-axis heat: heat from feed-axis motion (the ball screw) moves the tool.

Term: one more displacement column, a lag of the recorded feed rate, with one weight. Needs the
feed rate (`--feed COLUMN`)."""
from __future__ import annotations

import numpy as np

from thermoplc.physics.effects.definition import DisplacementTerm, EffectDefinition
from thermoplc.physics.effects.evidence import HOUR, time_constant_at_bound

MAX_FEED_TAU_S = 6 * HOUR  # a ball screw and its nut heat through in minutes to a couple of hours


def describe(sim, series) -> dict:
    d = sim.displacement
    return {"tau_h": d.tau_feed_s / HOUR, "um_per_m_min": d.phi * 1000.0}


def columns(series, temps, lagged, t0, tau_s: float) -> list:
    """A lag of the feed rate from rest."""
    from thermoplc.physics.primitives import lag, pole
    return [lag(series.feed, pole(tau_s, series.dt), 0.0)]


def draw(rng: np.random.Generator, clean: dict, train: slice, machine) -> dict:
    return {"tau_h": float(rng.uniform(0.3, 2.0)), "um_per_K": float(rng.uniform(2.0, 6.0))}


def untestable(train) -> str | None:
    if train.feed is None:
        return "needs --feed COLUMN, the feed-axis rate"
    if np.ptp(train.feed) == 0:
        return "the feed rate never changes in the training part"
    return None


def implausible(sim, train, routines) -> str | None:
    tau = sim.displacement.tau_feed_s
    if tau > MAX_FEED_TAU_S:
        return (f"time constant {tau / HOUR:.3g} h: slower than a feed axis heats (at most "
                f"{MAX_FEED_TAU_S / HOUR:g} h), a stand-in for a slow structure or the air")
    return time_constant_at_bound(tau, 130.0, 23 * HOUR)


EFFECT = EffectDefinition(
    name="feed_axis_heat", rank=7, bounds=(("tau_h", 0.0, 1000.0), ("um_per_K", -10000.0, 10000.0)), description="heat from feed-axis motion (ball screw) moves the tool",
    defaults=(("tau_h", 0.5), ("um_per_K", 3.0)), positive=("tau_h",),
    part="displacement", added_parameters=lambda sensors: 2, driven_by="feed",
    displacement=DisplacementTerm("feed", "tau_feed_s", "phi", per_sensor=False, search_s=(120.0, 24 * HOUR),
                                  columns=columns, pole=("AF", "BF"), weight="phi"),
    describe=describe, draw=draw, untestable=untestable, implausible=implausible)
