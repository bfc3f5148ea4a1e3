"""Can the data decide? Naming an effect the training part cannot show would be made up.

A recording too short or without running says nothing about heat; an effect that needs speeds on
both sides of a threshold, standstills after running, several coolant cycles or a whole day of the
hall air is not tested where the training part lacks them; a held-out window at a speed the training part never ran is
reported as extrapolation rather than blamed on a missing effect.
"""
from __future__ import annotations

import numpy as np

from thermoplc.diagnosis.windows import Window, rms
from thermoplc.physics import primitives
from thermoplc.physics.effects import definition_of
from thermoplc.physics.primitives import Series

HOUR = 3600.0
MIN_TRAIN_S = 6 * HOUR  # the slowest sensor time constants are about an hour; less cannot separate them
MIN_RUNNING_S = 1 * HOUR


def recording_problem(train: list[Series]) -> str | None:
    """Why the training part (of every training run together) cannot support any diagnosis, or None."""
    span = sum(run.rows * run.dt for run in train)
    if span < MIN_TRAIN_S:
        return (f"the training part covers {span / HOUR:.1f} h; at least {MIN_TRAIN_S / HOUR:g} h are needed to "
                f"separate the sensors' time constants (about an hour each)")
    speeds = np.concatenate([run.n for run in train])
    running = np.count_nonzero(speeds > primitives.stopped_threshold(speeds)) * train[0].dt
    if running < MIN_RUNNING_S:
        return (f"the spindle runs {running / HOUR:.2f} h in the training part; at least {MIN_RUNNING_S / HOUR:g} h "
                f"of running are needed to learn how speed heats the machine")
    return None


def untestable(train: Series, name: str) -> str | None:
    """Why the training part cannot show this effect, or None (the effect's record says)."""
    return definition_of(name).untestable(train)


def look_alike(train: Series, name: str) -> tuple[str, str] | None:
    """Another effect that fits the training part as well as `name` by construction, and why; or None."""
    return definition_of(name).look_alike(train)


def unseen_conditions(train: Series, run: Series, held_start: int, window: Window) -> str | None:
    """Where a window of `run` extrapolates beyond the training rows `train` (of every training run) in speeds
    or ambient, or None; `held_start` is the run's first held-out row (a window before it is training)."""
    if window.stop <= held_start:
        return None
    shared = primitives.Shared(stopped_rpm=primitives.stopped_threshold(train.n))
    trained = primitives.speed_levels(train.n, shared)
    start = max(window.start, held_start)
    seen = primitives.speed_levels(run.n[start:window.stop], shared)
    tolerance = primitives.SPEED_GAP_SHARE * max(float(np.max(np.abs(train.n))), float(np.max(np.abs(run.n))), 1.0)
    outside = [float(v) for v in seen if not len(trained) or v > trained.max() + tolerance
               or v < trained.min() - tolerance]
    notes = []
    if outside:
        notes.append("speeds outside the training part's " + (f"{trained.min():.0f}..{trained.max():.0f} rpm: "
                     if len(trained) else "(it never ran): ") + ", ".join(f"{v:.0f}" for v in outside) + " rpm")
    te_train = train.te
    te_window = run.te[start:window.stop]
    if len(te_window) and (te_window.min() < te_train.min() - 0.5 or te_window.max() > te_train.max() + 0.5):
        notes.append(f"ambient {te_window.min():.1f}..{te_window.max():.1f} degC outside the training part's "
                     f"{te_train.min():.1f}..{te_train.max():.1f} degC")
    return "ran at " + "; ".join(notes) if notes else None


def no_compensation_rmse(parts) -> float | None:
    """The held-out target's RMSE with nothing compensated (predicting 0, as `fit` counts it: a displacement
    measured from the machine's start), on its measured rows; None without any."""
    return rms(parts.joined().target[parts.n_train:])


def worse_than_none(baseline_rmse: float, none_rmse: float | None) -> str | None:
    """Why no effect is judged on a baseline that predicts the held-out target no better than no compensation, or
    None. Its disagreement there is its own extrapolation: any candidate that bends it back is credited with
    repairing the baseline, not with physics the machine has (FL_THERMAL ch3 on a 48 h structure-lag grid:
    24.96 um held out against 24.92 with nothing compensated)."""
    if none_rmse is None or baseline_rmse is None or baseline_rmse < none_rmse:
        return None
    return (f"the baseline predicts the held-out target no better than no compensation (RMSE {baseline_rmse:.4g} "
            f"against {none_rmse:.4g} um): its disagreement there is its own extrapolation, and no effect is judged "
            f"on it")
