"""What a training part shows, for the effects' evidence rules: speed groups, standstills after
running, its span. The simulation is imported when a rule runs, not when the names are listed."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from thermoplc.physics.primitives import Series

HOUR = 3600.0
MIN_DAY_S = 24 * HOUR  # a slow structure or an ambient coupling: a whole daily cycle of the hall air


def speed_groups(train: "Series") -> int:
    """How many groups of running speeds the training part has (standstill not counted)."""
    from thermoplc.physics import primitives
    return len(primitives.speed_levels(train.n, primitives.Shared(stopped_rpm=primitives.stopped_threshold(train.n))))


def standstills(train: "Series", at_least_s: float) -> int:
    """Stretches at rest of at least `at_least_s`, each after running."""
    from thermoplc.physics import primitives
    at_rest = train.n <= primitives.stopped_threshold(train.n)
    edges = np.flatnonzero(np.diff(np.r_[0, at_rest.astype(int), 0]))
    ran_before = np.r_[False, np.cumsum(~at_rest)[:-1] > 0]
    return sum((stop - start) * train.dt >= at_least_s and ran_before[start]
               for start, stop in zip(edges[::2], edges[1::2]))


def shorter_than_a_day(train: "Series") -> str | None:
    """Why a lag of hours in the displacement cannot be told apart on this training part, or None."""
    span = train.rows * train.dt
    if span < MIN_DAY_S:
        return (f"the training part covers {span / HOUR:.2f} h; a lag of hours in the displacement is told from the "
                f"sensors' own lags and from the ambient only over a whole day ({MIN_DAY_S / HOUR:g} h)")
    return None


def time_constant_at_bound(tau_s: float, low_s: float, high_s: float) -> str | None:
    """A fitted time constant on the edge of its searched range is a stand-in, not the named physics."""
    if not low_s < tau_s < high_s:
        return f"time constant {tau_s / HOUR:.3g} h at the end of the searched range"
    return None
