"""What a training part shows, for the effects' evidence rules: speed groups, standstills after
running, its span. The lumped model's primitives are imported when a rule runs, not when the names are
listed."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from thermoplc.physics.primitives import Series

HOUR = 3600.0
MIN_DAY_S = 24 * HOUR  # a slow structure or an ambient coupling: a whole daily cycle of the hall air
# or, for an ambient coupling, the air moved by kelvins (a climate chamber's set level, a hall's heating
# switched on) and then recorded for hours: a lag of 1-8 h shows its shape beside the sensors' lags of about
# an hour, whatever the recording's length
MIN_AIR_MOVE_K = 3.0  # a hall's daily swing seldom moves the air this far within a run; a chamber's set levels do
MIN_WATCHED_AFTER_S = 3 * HOUR
AVERAGE_S = 1800.0  # the air's move is that of its 30 min average, from the first reading


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
                f"sensors' own lags only over a whole day ({MIN_DAY_S / HOUR:g} h)")
    return None


def air_move(train: "Series") -> float:
    """How far the air's 30 min average moves from its first reading before the last `MIN_WATCHED_AFTER_S`, in K (0
    when shorter): a reading's glitch or a door opened for minutes moves no structure."""
    watched = train.rows - int(round(MIN_WATCHED_AFTER_S / train.dt))
    width = max(1, int(round(AVERAGE_S / train.dt)))
    if watched < width:
        return 0.0
    sums = np.cumsum(np.r_[0.0, train.te[:watched]])
    averaged = (sums[width:] - sums[:-width]) / width
    return float(np.max(np.abs(averaged - train.te[0])))


def ambient_unseen(train: "Series") -> str | None:
    """Why an ambient coupling cannot be told apart on this training part, or None: neither a whole day of hall
    air nor an air move of kelvins watched for hours after it."""
    if shorter_than_a_day(train) is None or (moved := air_move(train)) >= MIN_AIR_MOVE_K:
        return None
    return (f"the training part covers {train.rows * train.dt / HOUR:.2f} h and its air moves {moved:.2f} K before "
            f"its last {MIN_WATCHED_AFTER_S / HOUR:g} h; a lag of hours in the displacement is told from the "
            f"sensors' own lags and from the ambient over a whole day ({MIN_DAY_S / HOUR:g} h) or after the air "
            f"(its {AVERAGE_S / 60:g} min average) moved by at least {MIN_AIR_MOVE_K:g} K with "
            f"{MIN_WATCHED_AFTER_S / HOUR:g} h of recording after it")


def time_constant_at_bound(tau_s: float, low_s: float, high_s: float) -> str | None:
    """A fitted time constant on the edge of its searched range is a stand-in, not the named physics."""
    if not low_s < tau_s < high_s:
        return f"time constant {tau_s / HOUR:.3g} h at the end of the searched range"
    return None
