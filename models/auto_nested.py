"""`fit --model auto` on a campaign, judged with the sensor selection nested inside the folds.

Choosing the sensors on the same held-out runs that then report the error makes the reported error
optimistic (the choice has seen the runs it is scored on). On a campaign the choice is repeated
inside each of `OUTER_FOLDS` folds of whole runs (or each group): forward selection of sensors by
MLR on the training runs alone (inner folds of whole runs), the kind `auto` ranked first fitted on
those runs with that set, scored on the held-out runs, each from its first row. The pooled error is
the written model's held-out evidence, which the acceptance gate reads. The kind itself is chosen
once, by the ranking on the same folds: one choice among a handful, a mild optimism that is stated.

Forward selection runs on a direct ridge path (the rises of each run computed once), not through
`fit`, so a campaign of 40 runs x 23 sensors is chosen in seconds; the map is the one `fit --model
mlr` fits (models/ridge.py, the same weights).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.models import ridge
from thermoplc.models.crossval import contiguous, fold_of, pooled, run_folds
from thermoplc.models.fit import FitRequest, evaluate, fit
from thermoplc.models.table import Table

OUTER_FOLDS = 5
INNER_FOLDS = 5


@dataclass(frozen=True)
class RunRises:
    """One run's temperature rises since its first row and its measured target, on the measured rows."""
    rises: dict  # column -> rises on the measured rows
    target: np.ndarray


def run_rises(tables: list[Table], request: FitRequest) -> list[RunRises]:
    out = []
    for t in tables:
        y = t.columns[request.target]
        measured = np.isfinite(y)
        out.append(RunRises({c: (t.columns[c] - t.columns[c][0])[measured] for c in request.temps}, y[measured]))
    return out


def mlr_error(runs: list[RunRises], columns: tuple[str, ...], folds: list[list[int]]) -> float:
    """Pooled held-out RMSE of MLR on `columns` over `folds` (lists of run indices held out together)."""
    squares, rows = 0.0, 0
    everyone = [k for fold in folds for k in fold]
    for held in folds:
        train = [k for k in everyone if k not in held]
        x = np.vstack([np.column_stack([runs[k].rises[c] for c in columns]) for k in train])
        y = np.concatenate([runs[k].target for k in train])
        try:
            fitted = ridge.fit_linear(x, y, list(columns))
        except UserError:
            return math.inf  # a sensor flat on these runs
        for k in held:
            residual = runs[k].target - fitted.intercept - np.column_stack([runs[k].rises[c] for c in columns]) \
                @ fitted.slopes
            squares += float(residual @ residual)
            rows += len(residual)
    return math.sqrt(squares / rows) if rows else math.inf


def forward_selection(runs: list[RunRises], candidates: tuple[str, ...], folds: list[list[int]],
                      max_sensors: int) -> list[tuple[str, ...]]:
    """Sensors added one at a time, each the one that gives MLR the lowest error over `folds`: the sets
    of 1..`max_sensors` sensors it passes through."""
    chosen: list[str] = []
    sets = []
    for _ in range(min(max_sensors, len(candidates))):
        scored = [(mlr_error(runs, (*chosen, c), folds), k, c) for k, c in enumerate(candidates) if c not in chosen]
        scored = [s for s in scored if math.isfinite(s[0])]
        if not scored:
            break
        chosen.append(min(scored)[2])
        sets.append(tuple(chosen))
    return sets


def _best_set(runs: list[RunRises], candidates: tuple[str, ...], folds: list[list[int]], max_sensors: int):
    sets = forward_selection(runs, candidates, folds, max_sensors)
    if not sets:
        raise UserError("no sensor set could be fitted on these runs")
    return min(sets, key=lambda s: (mlr_error(runs, s, folds), len(s)))


def nested_auto(tables: list[Table], request: FitRequest, max_sensors: int, groups: dict | None = None,
                say: Callable[[str], None] | None = None) -> dict:
    """The held-out evidence of `auto`'s choice of `request.kind` on a campaign with the sensor selection
    nested (module docstring), in the model file's form, with the set each outer fold chose."""
    runs = run_rises(tables, request)
    outer = run_folds(tables, min(OUTER_FOLDS, len(tables)), groups)
    found, choices = [], []
    for label, held in outer:
        if say:
            say(f"auto, nested: choosing the sensors without {label}")
        train = [k for k in range(len(tables)) if k not in held]
        inner = contiguous(train, INNER_FOLDS)
        if len(inner) < 2:
            raise UserError(f"auto on a campaign: fold {label} leaves {len(train)} run to choose the sensors on; "
                            f"give more runs")
        sensors = _best_set(runs, request.temps, inner, max_sensors)
        model = fit([tables[k] for k in train], replace(request, temps=sensors, train_until=math.inf, train_rows=None))
        metrics = evaluate(model, [tables[k] for k in held], [0] * len(held))["held_out"]
        found.append(fold_of(label, model.metrics["train"]["rows"], metrics))
        choices.append({"fold": label, "sensors": list(sensors)})
    protocol = (f"nested cross-validation: {request.kind} with the sensors chosen inside each of {len(found)} "
                f"{'groups' if groups is not None else 'folds of whole runs'} ({len(tables)} runs)")
    return {**pooled(found), "protocol": protocol, "sensor_choices": choices, "folds_detail": [f.as_dict() for f in found]}
