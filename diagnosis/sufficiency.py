"""Can the data decide? Naming an effect the training part cannot show would be made up.

A recording too short or without running says nothing about heat; an effect that needs speeds on
both sides of a threshold, standstills after running, several coolant cycles or a whole day of the
hall air is not tested where the training part lacks them; a held-out window at a speed the training part never ran is
reported as extrapolation rather than blamed on a missing effect.
"""
from __future__ import annotations

import numpy as np

from thermoplc.diagnosis.windows import Window
from thermoplc.models import simulation as sim_
from thermoplc.models.simulation import Series, Simulation

HOUR = 3600.0
MIN_TRAIN_S = 6 * HOUR  # the slowest sensor time constants are about an hour; less cannot separate them
MIN_RUNNING_S = 1 * HOUR
MIN_STANDSTILLS = 2  # stretches at rest of at least STANDSTILL_S, each after running
STANDSTILL_S = 1800.0
MIN_DAY_S = 24 * HOUR  # a slow structure or an ambient coupling: a whole daily cycle of the hall air
MIN_RELAY_SWITCHES = 3  # on, off, on: one cycle and the start of another


def recording_problem(train: Series) -> str | None:
    """Why the training part cannot support any diagnosis, or None."""
    span = train.rows * train.dt
    if span < MIN_TRAIN_S:
        return (f"the training part covers {span / HOUR:.1f} h; at least {MIN_TRAIN_S / HOUR:g} h are needed to "
                f"separate the sensors' time constants (about an hour each)")
    running = np.count_nonzero(train.n > sim_.stopped_threshold(train.n)) * train.dt
    if running < MIN_RUNNING_S:
        return (f"the spindle runs {running / HOUR:.2f} h in the training part; at least {MIN_RUNNING_S / HOUR:g} h "
                f"of running are needed to learn how speed heats the machine")
    return None


def _standstills(train: Series, stopped_rpm: float) -> int:
    at_rest = train.n <= stopped_rpm
    edges = np.flatnonzero(np.diff(np.r_[0, at_rest.astype(int), 0]))
    ran_before = np.r_[False, np.cumsum(~at_rest)[:-1] > 0]
    return sum((stop - start) * train.dt >= STANDSTILL_S and ran_before[start]
               for start, stop in zip(edges[::2], edges[1::2]))


def speed_groups(train: Series) -> int:
    """How many groups of running speeds the training part has (standstill not counted)."""
    return len(sim_.speed_levels(train.n, sim_.Shared(stopped_rpm=sim_.stopped_threshold(train.n))))


def untestable(train: Series, name: str) -> str | None:
    """Why the training part cannot show this effect, or None."""
    if name == "sensor_offset":
        return ("a constant offset reads as a standstill heat load at that sensor, which the baseline fits per "
                "sensor (a real machine is rarely at the air's temperature with the spindle still), and the "
                "displacement follows temperature rises from the first call: no data can tell the two apart")
    groups = speed_groups(train)
    if name == "gear_ratio_switch" and groups < 2:
        return f"the training part runs at {groups} speed group(s); a threshold needs speeds on both sides"
    if name == "nonlinear_speed_heat" and groups < 3:
        return f"the training part runs at {groups} speed group(s); a curve needs at least three"
    span = train.rows * train.dt
    if name in ("slow_structure", "ambient_coupling") and span < MIN_DAY_S:
        return (f"the training part covers {span / HOUR:.2f} h; a lag of hours in the displacement is told from the "
                f"sensors' own lags and from the ambient only over a whole day ({MIN_DAY_S / HOUR:g} h)")
    if name == "stop_convection" and _standstills(train, sim_.stopped_threshold(train.n)) < MIN_STANDSTILLS:
        return (f"the training part has fewer than {MIN_STANDSTILLS} standstills of {STANDSTILL_S / 60:g} min "
                f"after running")
    return None


def look_alike(train: Series, name: str) -> tuple[str, str] | None:
    """Another effect that fits the training part as well as `name` by construction, and why; or None.
    Through two speed groups and standstill any heat curve is a switch between them."""
    groups = speed_groups(train)
    if name == "gear_ratio_switch" and groups < 3:
        return "nonlinear_speed_heat", (f"a switch fits, but the training part runs at {groups} speed groups: a "
                                        "switch between them and a curve through them fit alike, and a curve "
                                        "is tested only from three groups")
    return None


def relay_too_quiet(sim: Simulation, train: Series) -> str | None:
    """A fitted coolant relay that switches too rarely in training is a step, not a coolant."""
    if not sim.has("coolant_switching"):
        return None
    state = sim_.closed_loop_cooling(train, sim.shared, sim.sensors, sim.effects)
    switches = int(np.count_nonzero(np.diff(np.r_[0.0, state])))
    if switches < MIN_RELAY_SWITCHES:
        return (f"the fitted relay switches {switches} time(s) in the training part; at least {MIN_RELAY_SWITCHES} "
                f"are needed to tell a coolant from a one-off change")
    return None


def unseen_conditions(series: Series, n_train: int, window: Window) -> str | None:
    """Where a held-out window extrapolates beyond the training part (speeds or ambient), or None."""
    if window.stop <= n_train:
        return None
    shared = sim_.Shared(stopped_rpm=sim_.stopped_threshold(series.n[:n_train]))
    trained = sim_.speed_levels(series.n[:n_train], shared)
    start = max(window.start, n_train)
    seen = sim_.speed_levels(series.n[start:window.stop], shared)
    tolerance = sim_.SPEED_GAP_SHARE * max(float(np.max(np.abs(series.n))), 1.0)
    outside = [float(v) for v in seen if not len(trained) or v > trained.max() + tolerance
               or v < trained.min() - tolerance]
    notes = []
    if outside:
        notes.append("speeds outside the training part's " + (f"{trained.min():.0f}..{trained.max():.0f} rpm: "
                     if len(trained) else "(it never ran): ") + ", ".join(f"{v:.0f}" for v in outside) + " rpm")
    te_train = series.te[:n_train]
    te_window = series.te[start:window.stop]
    if len(te_window) and (te_window.min() < te_train.min() - 0.5 or te_window.max() > te_train.max() + 0.5):
        notes.append(f"ambient {te_window.min():.1f}..{te_window.max():.1f} degC outside the training part's "
                     f"{te_train.min():.1f}..{te_train.max():.1f} degC")
    return "ran at " + "; ".join(notes) if notes else None
