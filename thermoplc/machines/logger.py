"""A data logger's file, as real ones are written (`twin --logger`): every quarter of the block's cycle for
the first FAST_MINUTES (a logger's start-up rate), then every cycle, each time stamp off by up to JITTER_S
(the logger's clock against the machine's), rounded to 0.1 s (finer for a fast cycle: every stamp stays its
own, as a logger's are). The values are those the machine had at the
nominal instant; the file is what `--resample` (recordings/resample.py) takes back onto the cycle."""
from __future__ import annotations

import numpy as np

FAST_MINUTES = 16.0
FAST_SHARE = 4  # the start-up rate: this many rows per cycle
JITTER_S = 1.0


def fast_period(dt: float) -> float:
    """The period to simulate at, so that the logger's start-up rows are among the simulated ones."""
    return dt / FAST_SHARE


def logged(columns: dict, dt: float, seed: int, time_column: str = "time_s") -> dict:
    """`columns` simulated every fast_period(dt) s, as the logger wrote them: the start-up rows, then every
    FAST_SHARE-th, time stamps jittered (never out of order: the jitter is under half the fast period or shrunk)."""
    t = columns[time_column]
    fast = t - t[0] < FAST_MINUTES * 60
    rows = np.flatnonzero(fast | (np.arange(len(t)) % FAST_SHARE == 0))
    rng = np.random.default_rng([seed, 41])
    jitter = min(JITTER_S, 0.45 * fast_period(dt))
    decimals = max(1, int(np.ceil(-np.log10(fast_period(dt) / 10))))  # a step of at most a tenth of the fastest rate
    stamps = np.round(t[rows] + rng.uniform(-jitter, jitter, len(rows)) * (np.arange(len(rows)) > 0), decimals)
    return {name: (stamps if name == time_column else values[rows]) for name, values in columns.items()}
