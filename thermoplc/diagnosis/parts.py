"""The runs a diagnosis reads, and which rows of each are the training part.

A recording split in time is one run whose first rows train; a campaign is several runs, each
training or held out whole (each starts from its own state, as the block after a Reset). The
judges pool over runs: every channel's residual is one array with all training rows first, run by
run, then all held-out rows, so the information criteria, the held-out evidence and the effective
rows count every run. Windows are found per run, in its own time order.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from thermoplc.physics import primitives

from thermoplc.physics import simulation as sim_
from thermoplc.physics.primitives import Series


@dataclass(frozen=True, eq=False)
class Parts:
    runs: tuple[Series, ...]
    train_rows: tuple[int, ...]  # per run: its first rows that train (all, none, or a split recording's part)
    labels: tuple[str, ...] = ()  # each run's name in tables

    @property
    def n_train(self) -> int:
        return sum(self.train_rows)

    @property
    def rows(self) -> int:
        return sum(run.rows for run in self.runs)

    @property
    def train(self) -> list[Series]:
        """The training part of every run that has one."""
        return [run.head(k) for run, k in zip(self.runs, self.train_rows) if k > 0]

    @property
    def campaign(self) -> bool:
        return len(self.runs) > 1

    def pool(self, per_run: list[np.ndarray]) -> np.ndarray:
        """One array per run (in time order) as the pooled array: training rows first, then held-out rows."""
        return np.concatenate([x[:k] for x, k in zip(per_run, self.train_rows)]
                              + [x[k:] for x, k in zip(per_run, self.train_rows)])

    def unpool(self, pooled: np.ndarray) -> list[np.ndarray]:
        """The pooled array back as one array per run, in time order."""
        out, train_at, held_at = [], 0, self.n_train
        for run, k in zip(self.runs, self.train_rows):
            out.append(np.concatenate([pooled[train_at:train_at + k], pooled[held_at:held_at + run.rows - k]]))
            train_at += k
            held_at += run.rows - k
        return out

    def joined(self) -> Series:
        """Every run's columns pooled in the same order, for what does not depend on the dynamics (noise, speed
        groups, ranges, parameters in engineering units): a time axis per row is kept, the series is no run."""
        first = self.runs[0]
        pooled = lambda get: self.pool([get(run) for run in self.runs])
        return replace(first, t=pooled(lambda r: r.t), n=pooled(lambda r: r.n), te=pooled(lambda r: r.te),
                       temps=pooled(lambda r: r.temps),
                       target=pooled(lambda r: r.target),
                       feed=None if first.feed is None else pooled(lambda r: r.feed))

    def seen_held_out(self) -> np.ndarray:
        """Per pooled held-out row, whether the training rows ran at its speed: standing, or running within the
        training's running speeds (a gap of `SPEED_GAP_SHARE` of the top speed beyond either end). A held-out row
        at a speed the training never ran judges how a fit extrapolates, not whether an effect is there
        (FL_THERMAL's held-out part runs at 500, 4500 and 5000 rpm, its training part at 1250-3750)."""
        return _seen(self)


@lru_cache(maxsize=8)
def _seen(parts: Parts) -> np.ndarray:
    speeds = parts.pool([run.n for run in parts.runs])
    train, held = speeds[:parts.n_train], speeds[parts.n_train:]
    stopped = sim_.stopped_threshold(train)
    running = train[train > stopped]
    if not len(running):
        return held <= stopped
    tolerance = primitives.SPEED_GAP_SHARE * max(float(np.max(np.abs(train))), 1.0)  # a held-out spike widens nothing
    return (held <= stopped) | ((held >= running.min() - tolerance) & (held <= running.max() + tolerance))


def single(series: Series, n_train: int) -> Parts:
    """A recording split in time: its first `n_train` rows train, the rest are held out."""
    return Parts((series,), (n_train,))
