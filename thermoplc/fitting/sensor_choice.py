"""`fit --choose-sensors N`: a kind's sensors chosen from the `--temps` candidates on its training rows.

A user's guess of two to four sensors is rarely the set the data support (issue 50: on a lathe with 23
sensors, every kind on four hand-picked ones was 1.5-2x a ridge on all of them). Every single sensor
and every pair is scored by the held-out error of a ridge map on the rises (MLR's, base/ridge.py):
two sensors that only explain the drift together (a difference of two heat paths) are found although
neither leads alone, where plain forward selection locks onto the best single one. From the best
pair on, sequential floating forward selection (Pudil et al. 1994): the sensor added at each step is
the one that lowers the error most, and after each addition a sensor chosen earlier is dropped while
that gives a better set of its size than any seen. The search runs `LOOK_PAST` sizes beyond N (a floating step back
from a larger set can find a better set of size N), and the set kept is the smallest of at most N
whose error no larger set of at most N lowers by `MIN_GAIN` or more (a sensor that buys 0.2 % is noise
fitted, and one more input the PLC wires). The block reads the chosen sensors in the order of
`--temps`. A candidate that does not move on the training rows has no slope and is not chosen. The error is measured on
the training rows alone - leaving out each training run in turn when there are several, else forward
(first two thirds fitted, last third scored) - so inside cross-validation every fold chooses on its
own training runs, and the held-out evidence `fit` writes is that of the whole procedure.

The linear map on rises stands in for every kind: it is the information each kind maps to the drift
(lags, running sums and filters are built on the same readings), and it scores a set from each run's
sums of products in well under a millisecond, where a genetic-algorithm kind takes minutes per set.
The best set of each size is in the model file (`fit.sensor_choice`), so a reviewer sees why it stopped.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.base import ridge

MIN_GAIN = 0.02  # a larger set is kept when it lowers the error by at least this share
LOOK_PAST = 2  # sizes searched beyond the most asked for


@dataclass(frozen=True)
class Choice:
    candidates: tuple[str, ...]
    chosen: tuple[str, ...]
    best: tuple[tuple[tuple[str, ...], float], ...]  # the best set of each size 1.. and its error, um
    by: str  # how the error was measured
    still: tuple[str, ...] = ()  # candidates that do not move on the training rows

    def log(self) -> dict:
        return {"candidates": list(self.candidates), "chosen": list(self.chosen), "by": self.by,
                "best_of_each_size": [{"sensors": list(s), "rmse_um": e} for s, e in self.best],
                **({"not_moving": list(self.still)} if self.still else {})}


@dataclass(frozen=True)
class TrainingRises:
    """The candidates' rises since each run's first row against the target, on the measured training rows, as
    sums of products per run (or per part of one recording) and the parts that are scored."""
    sums: ridge.RunSums
    held: tuple[int, ...]
    by: str
    still: tuple[int, ...]  # candidates whose rise never moves on the measured training rows


def training_rises(columns_of_runs: list[dict[str, np.ndarray]], target: str, candidates: tuple[str, ...]
                   ) -> TrainingRises:
    """From each run's training rows (column -> values). One recording is cut where forward validation cuts
    it (base/ridge.py): the first two thirds fit, the last third is scored."""
    designs, targets = [], []
    for columns in columns_of_runs:
        measured = np.isfinite(columns[target])
        designs.append(np.column_stack([(columns[c] - columns[c][0])[measured] for c in candidates]))
        targets.append(columns[target][measured])
    design, y = np.vstack(designs), np.concatenate(targets)
    still = tuple(int(i) for i in np.flatnonzero(np.ptp(design, axis=0) == 0.0))  # no rise to fit a slope to
    if len(targets) >= 2:
        return TrainingRises(ridge.RunSums.of(design, y, [len(t) for t in targets]), tuple(range(len(targets))),
                             f"leaving out each of {len(targets)} training runs", still)
    cut = ridge.validation_cut(len(y))
    if cut is None:
        raise UserError(f"--choose-sensors: {len(y)} measured training rows; choosing sensors on one recording fits "
                        f"two thirds and scores the last third, {ridge.MIN_VALIDATION_ROWS} rows at least each: train "
                        f"on more rows, or on several runs")
    return TrainingRises(ridge.RunSums.of(design, y, [cut, len(y) - cut]), (1,),
                         "forward: fitted on the first two thirds of the training rows, scored on the last third", still)


def choose(data: TrainingRises, candidates: tuple[str, ...], most: int) -> Choice:
    """At most `most` of `candidates` by sequential floating forward selection (module docstring)."""
    error = lambda chosen: min(ridge.run_errors(data.sums, sorted(chosen), ridge.WEIGHTS, data.held))
    everyone = [c for c in range(len(candidates)) if c not in data.still]
    if not everyone:
        raise UserError("--choose-sensors: no candidate of --temps moves on the training rows")
    search = min(most + LOOK_PAST, len(everyone))
    best = {1: min((error((c,)), (c,)) for c in everyone)}
    if search >= 2:
        best[2] = min((error((a, b)), (a, b)) for a in everyone for b in everyone if a < b)
    current = best[max(best)][1]
    while len(current) < search:
        found, added = min((error((*current, c)), c) for c in everyone if c not in current)
        current = (*current, added)
        if len(current) not in best or found < best[len(current)][0]:
            best[len(current)] = (found, current)
        else:
            current = best[len(current)][1]  # a floating step came back to a size it had done better at
        while len(current) > 2:  # drop an earlier sensor while that beats the best set of the smaller size
            dropped, leave = min((error(tuple(s for s in current if s != c)), c) for c in current[:-1])
            if dropped >= best[len(current) - 1][0]:
                break
            current = tuple(s for s in current if s != leave)
            best[len(current)] = (dropped, current)
    sizes = sorted(k for k in best if k <= most)
    keep = next(k for k in sizes if all(best[j][0] > (1 - MIN_GAIN) * best[k][0] for j in sizes if j > k))
    named = lambda indices: tuple(candidates[i] for i in sorted(indices))  # the order of --temps
    return Choice(tuple(candidates), named(best[keep][1]),
                  tuple((named(best[k][1]), float(best[k][0])) for k in sizes), data.by,
                  named(data.still))
