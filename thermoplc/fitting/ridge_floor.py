"""The floor a fitted kind is judged beside (issue 62): a ridge on the rises of the same temperatures, held out alike.

A kind that predicts held-out runs no better than a ridge on its own sensors' rises (each temperature since its
run's first row, standardised, the weight chosen leaving runs out inside each fold: base/ridge.py) earns its
states, lags and bins nothing: on FL_THERMAL's 6 h runs (ch3, the best 4 of 15 sensors) gm1n was 2.2 x and bayes
3.1 x that floor. `fit` prints the ratio beside the held-out figure; the floor's folds are the kind's own: the
same runs held out (the runs refused for training left out of every fit), or on one recording the same blocks,
each predicted by a ridge on the rows before it.
"""
from __future__ import annotations

import math

import numpy as np

from thermoplc.base import ridge
from thermoplc.base.errors import UserError
from thermoplc.recordings.table import Table


def floor_temperatures(temps: tuple[str, ...], ambient: str | None) -> list[str]:
    """The request's temperatures and its ambient, once each."""
    return list(dict.fromkeys((*temps, *([ambient] if ambient else []))))


def _rises(table: Table, names: list[str], target: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(each temperature's rise since the run's first row, the target, the row numbers), the rows with a measured
    target."""
    x = np.column_stack([np.asarray(table.column(n), float) for n in names])
    y = np.asarray(table.column(target), float)
    measured = np.isfinite(y) & np.isfinite(x).all(axis=1)
    return (x - x[0])[measured], y[measured], np.flatnonzero(measured)


def _squares(train: list[tuple[np.ndarray, np.ndarray]], test: list[tuple[np.ndarray, np.ndarray]],
             names: list[str]) -> tuple[float, int]:
    """Sum of squared errors and rows of the ridge fitted on `train` (each a run) predicting `test`."""
    design = np.vstack([x for x, _ in train])
    target = np.concatenate([y for _, y in train])
    fitted = ridge.fit_linear(design, target, names, runs=[len(y) for _, y in train] if len(train) > 1 else None)
    errors = np.concatenate([y - fitted.intercept - x @ fitted.slopes for x, y in test])
    return float(errors @ errors), len(errors)


def ridge_floor(tables: list[Table], temps: tuple[str, ...], ambient: str | None, target: str,
                folds: list[tuple[tuple[int, ...], int, int]], left_out: tuple[int, ...] = ()) -> float | None:
    """Pooled held-out RMSE of the ridge over `folds`: (held-out runs, ) of a campaign, or ((), start, stop) of one
    recording's rows; None where a fold leaves it nothing to fit (a temperature flat on its training rows)."""
    names = floor_temperatures(temps, ambient)
    runs = [_rises(t, names, target) for t in tables]
    sse, rows = 0.0, 0
    try:
        for members, start, stop in folds:
            if members:
                train = [runs[k][:2] for k in range(len(tables)) if k not in members and k not in left_out]
                test = [runs[k][:2] for k in members]
            else:
                x, y, row = runs[0]
                train, test = [(x[row < start], y[row < start])], [(x[(row >= start) & (row < stop)],
                                                                     y[(row >= start) & (row < stop)])]
            if sum(len(y) for _, y in train) < len(names) + 2:
                return None
            s, n = _squares(train, test, names)
            sse, rows = sse + s, rows + n
    except UserError:
        return None
    return math.sqrt(sse / rows) if rows else None
