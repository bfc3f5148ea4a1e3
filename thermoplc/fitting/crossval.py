"""Blocked cross-validation: how well a kind, fitted as `fit` fits it, predicts data it never saw.

One recording is cut into whole contiguous blocks of equal duration (never random rows: the
rows of a thermal recording are hours-long correlated, and a row beside a training row is not
held out). A cut moves to the nearest standstill of the spindle within a quarter block when
the speed column is given (`--speed`), so a block is a run between standstills where the
recording has them.
The folds run forward: fold k fits on blocks 1..k-1 and predicts block k, continuing from the
end of the training part as the block on the PLC would (a model with state cannot be started in
the middle of a day without its history, and the past never learns from the future). Several
recordings (a campaign of runs) are held out whole: leave one run out (or K folds of whole runs,
or the groups of an attribute of the runs table), each run predicted from its first row, as a
freshly started block, by a fit on the other runs.

The model `fit` writes is then fitted on every row; its held-out evidence is the pooled error of
the folds, beside no compensation on the same rows, so `generate`'s acceptance rule judges the
procedure on data it was not fitted to.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np

from thermoplc.base.cluster import Cluster, Lost
from thermoplc.base.errors import ClusterError, UserError
from thermoplc.recordings.campaign import CampaignSource, run_labels
from thermoplc.fitting.broken_runs import Screening, screen_runs
from thermoplc.fitting.copies import refuse_copies
from thermoplc.fitting.fit import FitRequest, evaluate, fit, runs_named
from thermoplc.fitting.ridge_floor import floor_temperatures, ridge_floor
from thermoplc.models.model import Model
from thermoplc.models.reference import block_outputs, model_inputs, predict
from thermoplc.models.plausibility import DISAGREE
from thermoplc.models.safety import Limits
from thermoplc.recordings.table import Table

MIN_FOLDS, MAX_FOLDS = 2, 20
STANDSTILL_REACH = 0.25  # a cut moves to a standstill at most this share of a block away


@dataclass(frozen=True)
class Fold:
    label: str  # "rows 2881..5760" or the recording's file name
    train_rows: int
    rows: int  # held out
    rmse: float
    max_abs: float
    zero_rmse: float
    zero_max_abs: float
    sensors: tuple[str, ...] = ()  # the fold's own choice of sensors (fit --choose-sensors), else empty

    def as_dict(self) -> dict:
        return {k: (list(v) if k == "sensors" else v) for k, v in self.__dict__.items() if k != "sensors" or v}


def cuts(table: Table, time_column: str, folds: int, speed: str | None) -> list[int]:
    """Row indices where blocks 2..folds start: equal durations, each moved to the nearest row where
    the spindle stands (within `STANDSTILL_REACH` of a block) when a speed column is given."""
    if not MIN_FOLDS <= folds <= MAX_FOLDS:
        raise UserError(f"--folds {folds}: expected {MIN_FOLDS} to {MAX_FOLDS} blocks")
    t = table.columns[time_column]
    span = (t[-1] - t[0]) / folds
    starts = [int(np.searchsorted(t, t[0] + k * span)) for k in range(1, folds)]
    if speed is not None:
        stands = np.flatnonzero(table.columns[speed] == 0.0)
        reach = STANDSTILL_REACH * table.rows / folds
        for k, start in enumerate(starts):
            if len(stands):
                nearest = int(stands[np.argmin(np.abs(stands - start))])
                starts[k] = nearest if abs(nearest - start) <= reach else start
    bounds = [0, *starts, table.rows]
    if any(b - a < 10 for a, b in zip(bounds, bounds[1:])):
        raise UserError(f"{table.path}: --folds {folds} leaves a block of fewer than 10 rows; use fewer folds")
    return starts


def fold_of(label: str, train_rows: int, held: dict) -> Fold:
    """A fold from the held-out metrics of the model file's form."""
    return Fold(label, train_rows, held["rows"], held["rmse_um"], held["max_abs_um"], held["zero_rmse_um"],
                held["zero_max_abs_um"])


def run_folds(tables: list[Table], folds: int | None, groups: dict[str, list[int]] | None,
              left_out: tuple[int, ...] = ()) -> list[tuple[str, list[int]]]:
    """The held-out runs of each fold of a campaign, labelled: one group of the runs table per fold
    (`groups`), or `folds` contiguous sets of runs in their order (as many folds as runs: leave one run
    out, the default); the runs `left_out` (refused for training, fitting/broken_runs.py) in none, and a
    leave-one-run-out over the others where `folds` asked for one fold per run."""
    kept = [k for k in range(len(tables)) if k not in left_out]
    if groups is not None:
        groups = {value: [k for k in members if k not in left_out] for value, members in groups.items()}
        groups = {value: members for value, members in groups.items() if members}
        if len(groups) < 2:
            refused = (f" once the runs {', '.join(run_labels([tables[k].path for k in left_out]))} are refused for "
                       f"training (fit --keep-every-run keeps them)" if left_out else "")
            raise UserError(f"--group-by: every run is in the one group {next(iter(groups))!r}{refused}; a group "
                            f"predicted by a fit on the others needs at least two groups")
        return [(str(value), members) for value, members in groups.items()]
    folds = folds or len(tables)
    if not MIN_FOLDS <= folds <= len(tables):
        raise UserError(f"--folds {folds}: with {len(tables)} runs expected {MIN_FOLDS} to {len(tables)} folds "
                        f"(each fold holds whole runs; {len(tables)} leaves one run out)")
    labels = run_labels([t.path for t in tables])
    named = lambda members: (labels[members[0]] if len(members) == 1 else
                             f"runs {members[0] + 1}..{members[-1] + 1}" if len(members) == members[-1] - members[0] + 1
                             else f"{len(members)} runs {members[0] + 1}..{members[-1] + 1}")
    return [(named(members), members) for members in contiguous(kept, min(folds, len(kept)))]


def contiguous(indices: list[int], count: int) -> list[list[int]]:
    """`indices` in `count` contiguous folds of (nearly) equal size, in order (fewer when there are fewer)."""
    bounds = np.linspace(0, len(indices), min(count, len(indices)) + 1).round().astype(int)
    return [indices[a:b] for a, b in zip(bounds, bounds[1:]) if b > a]


@dataclass(frozen=True)
class Remote:
    """Folds run as tasks of a Dask cluster (base/cluster.py), each reading the campaign from `source` there."""
    cluster: Cluster
    source: CampaignSource


@dataclass(frozen=True)
class FoldTask:
    """One fold, all a task needs besides the runs: held-out runs `members` of a campaign, or one recording's
    rows `start`..`stop` predicted by a fit on the rows before (`members` empty)."""
    request: FitRequest
    time_column: str
    label: str
    members: tuple[int, ...] = ()
    start: int = 0
    stop: int = 0
    predictions: bool = False
    source: CampaignSource | None = None  # set for a task run elsewhere
    left_out: tuple[int, ...] = ()  # runs refused for training (fitting/broken_runs.py): in no fold's fit


@dataclass(frozen=True)
class FoldResult:
    fold: Fold
    per_run: tuple[dict, ...] = ()
    predictions: tuple[tuple[str, np.ndarray], ...] = ()  # (run's path, held-out prediction, float64)


def run_fold(task: FoldTask, tables: list[Table] | None = None) -> FoldResult:
    """A fold's fit and its held-out errors, on `tables` or on the runs its source reads where it runs."""
    tables = tables if tables is not None else task.source.read().tables
    if not task.members:
        model = _guarded(lambda: fit([tables[0].head(task.stop)], replace(task.request, train_until=None,
                                                                            train_rows=task.start), task.time_column),
                         f"fold {task.label}")
        return _with_choice(FoldResult(fold_of(f"rows {task.start + 1}..{task.stop}", task.start,
                                               model.metrics["held_out"])), model)
    held = [tables[k] for k in task.members]
    others = [t for k, t in enumerate(tables) if k not in task.members and k not in task.left_out]
    model = _guarded(lambda: fit(others, replace(task.request, train_until=math.inf, train_rows=None),
                                 task.time_column),
                     f"fold {task.label} (fitted without {runs_named(held)})")
    return _with_choice(judge_fold(model, tables, task.members, task.label, model.metrics["train"]["rows"],
                                   task.predictions), model)


def _with_choice(result: FoldResult, model: Model) -> FoldResult:
    """A fold that chose its own sensors (fit --choose-sensors) says which: the evidence is of the procedure."""
    choice = model.fit.get("sensor_choice")
    if choice is None:
        return result
    return replace(result, fold=replace(result.fold, sensors=tuple(choice["chosen"])))


def judge_fold(model, tables: list[Table], members, label: str, trained: int, predictions: bool) -> FoldResult:
    """The held-out errors of `model`, fitted on `trained` rows of the other runs, on the runs `members` of a
    campaign: the fold's pooled, each run's (by the model, and by its block inside the guards and limits it
    gets from the training runs: `guarded_errors`), and with `predictions` each run's float64 prediction."""
    labels = run_labels([t.path for t in tables])
    per_run, predicted = [], []
    for k in members:
        found = evaluate(model, [tables[k]], [0])["held_out"]
        if predictions:
            predicted.append((tables[k].path, predict(model, model_inputs(model, tables[k]), "f64")[model.target.name]))
        per_run.append({"run": labels[k], "fold": label, **fold_of(label, trained, found).as_dict(),
                        "rows_total": tables[k].rows, **guarded_errors(model, tables[k])})
    held = [tables[k] for k in members]
    return FoldResult(fold_of(label, trained, evaluate(model, held, [0] * len(held))["held_out"]),
                      tuple(per_run), tuple(predicted))


def _start_folds(tables: list[Table], tasks: list[FoldTask], remote: Remote | None):
    """The folds' results in order, computed here when asked for, or already running on the cluster."""
    if remote is None:
        return (run_fold(task, tables) for task in tasks)
    running = remote.cluster.run(run_fold, [replace(task, source=remote.source) for task in tasks], "fold",
                                 [f"fold {task.label}" for task in tasks])

    def in_order():  # a generator: nothing is waited for before the caller's first step
        results: list = [None] * len(tasks)
        for k, result in running:
            if isinstance(result, Lost):
                raise ClusterError(f"cross-validation, fold {tasks[k].label}: {result}")
            results[k] = result
        yield from results
    return in_order()


def read_columns(request: FitRequest) -> tuple[str, ...]:
    """The columns a fit of `request` reads: where two runs agree on these, one is the other's copy."""
    return tuple(c for c in (*request.temps, request.target, *request.extra_targets, request.speed, request.ambient)
                 if c)


def _run_tasks(tables: list[Table], request: FitRequest, time_column: str, folds: int | None,
               groups: dict[str, list[int]] | None, predictions: bool, left_out: tuple[int, ...] = ()) -> list[FoldTask]:
    refuse_copies(tables, "a fold predicted by a fit on its own copy is not held out", read_columns(request))
    return [FoldTask(request, time_column, label, tuple(members), predictions=predictions, left_out=left_out)
            for label, members in run_folds(tables, folds, groups, left_out)]


def _block_tasks(table: Table, request: FitRequest, time_column: str, folds: int | None) -> list[FoldTask]:
    starts = cuts(table, time_column, folds, request.speed)
    return [FoldTask(request, time_column, f"{k} (fitted on rows 1..{start})", start=start, stop=stop)
            for k, (start, stop) in enumerate(zip(starts, [*starts[1:], table.rows]), start=2)]


def _fold_tasks(tables: list[Table], request: FitRequest, time_column: str, folds: int | None,
                groups: dict[str, list[int]] | None, predictions: bool, left_out: tuple[int, ...] = ()) -> list[FoldTask]:
    """Whole runs held out (several runs or groups), or blocks of one recording."""
    if len(tables) > 1 or groups is not None:
        return _run_tasks(tables, request, time_column, folds, groups, predictions, left_out)
    return _block_tasks(tables[0], request, time_column, folds)


def cross_validate_runs(tables: list[Table], request: FitRequest, time_column: str, folds: int | None,
                        groups: dict[str, list[int]] | None = None,
                        predictions: dict | None = None) -> tuple[list[Fold], list[dict]]:
    """Each fold's runs predicted from their first row by a fit on the other runs; the folds' and each
    held-out run's errors beside no compensation. `predictions`, when given, receives each run's held-out
    prediction (float64) by its path, for the report."""
    tasks = _run_tasks(tables, request, time_column, folds, groups, predictions is not None)
    return _collect(_start_folds(tables, tasks, None), predictions)


def _collect(results, predictions: dict | None) -> tuple[list[Fold], list[dict]]:
    found, per_run = [], []
    for result in results:
        found.append(result.fold)
        per_run += result.per_run
        if predictions is not None:
            predictions.update(result.predictions)
    return found, per_run


def _guarded(run, where: str):
    try:
        return run()
    except UserError as exc:
        raise UserError(f"cross-validation, {where}: {exc}") from None


def pooled(folds: list[Fold]) -> dict:
    """The held-out metrics of all folds together, in the model file's form, and the spread."""
    rows = sum(f.rows for f in folds)
    mean_square = lambda key: sum(f.rows * getattr(f, key) ** 2 for f in folds) / rows
    return {"rows": rows, "rmse_um": math.sqrt(mean_square("rmse")), "max_abs_um": max(f.max_abs for f in folds),
            "zero_rmse_um": math.sqrt(mean_square("zero_rmse")), "zero_max_abs_um": max(f.zero_max_abs for f in folds),
            "folds": len(folds), "fold_rmse_um": [min(f.rmse for f in folds), max(f.rmse for f in folds)]}


def fit_cross_validated(tables: list[Table], request: FitRequest, folds: int | None, time_column: str = "time_s",
                        progress: Callable[[str], None] | None = None,
                        groups: dict[str, list[int]] | None = None,
                        predictions: dict | None = None, remote: Remote | None = None) -> Model:
    """Cross-validation, then the fit on every row of every run, carrying the folds' pooled errors as its
    held-out evidence, each fold's (and with several runs each run's) beside them. With `remote` the folds
    run on the cluster while this process fits on every row; the results are the same bits."""
    screening = screened(tables, request, groups)
    left_out = screening.refused_indices
    try:  # the folds go out first, so the cluster works while the fit on every row runs here
        tasks, refused = _fold_tasks(tables, request, time_column, folds, groups, predictions is not None,
                                     left_out), None
    except UserError as exc:
        tasks, refused = [], exc
    running = _start_folds(tables, tasks, remote)
    # the fit on every row first: a run's bad data is named as such, not as a fold's that left it out
    kept = [t for k, t in enumerate(tables) if k not in left_out]
    model = fit(kept, replace(request, train_until=math.inf, train_rows=None), time_column, progress)
    if refused is not None:
        raise refused
    found, per_run = _collect(running, predictions)
    if groups is not None:
        protocol = f"leave-one-group-out cross-validation over {len(found)} groups of {len(kept)} runs"
    elif len(tables) > 1:
        protocol = (f"leave-one-run-out cross-validation over {len(kept)} runs" if len(found) == len(kept)
                    else f"cross-validation over {len(found)} folds of whole runs ({len(kept)} runs)")
    else:
        protocol = f"forward cross-validation over {folds} blocks"
    held_out = {**pooled(found), "protocol": protocol}
    floor = ridge_floor(tables, request.temps, request.ambient, request.target,
                        [(t.members, t.start, t.stop) for t in tasks], left_out)
    if floor is not None:
        held_out["ridge_rmse_um"] = floor
    held_out.update(as_the_block_runs(per_run))
    extra = {"runs": per_run} if per_run else {}
    if screening.refused or screening.named:
        extra["run_screening"] = screening.log()
    if left_out:
        apart = judge_fold(model, tables, left_out, "refused for training", model.metrics["train"]["rows"],
                           predictions is not None)
        if predictions is not None:
            predictions.update(apart.predictions)
        held_out["protocol"] += f"; {len(left_out)} run{'s' if len(left_out) > 1 else ''} refused for training"
        with_them = pooled([*found, apart.fold])
        held_out["with_refused_runs"] = {k: with_them[k] for k in ("rows", "rmse_um", "max_abs_um", "zero_rmse_um")}
        extra["refused_runs"] = [{**judged.as_dict(), **{k: run[k] for k in ("rmse", "max_abs", "zero_rmse", "rows",
                                                                         *GUARDED)}}
                                 for judged, run in zip(screening.refused, _in_order(apart.per_run, screening))]
        held_out["with_refused_runs"].update(as_the_block_runs([*per_run, *apart.per_run]))
    return Model(**{**model.__dict__, "metrics": {**model.metrics, "held_out": held_out,
                                                   "cross_validation": [f.as_dict() for f in found], **extra}})


def guarded_errors(model: Model, table: Table) -> dict:
    """The errors of `model`'s block on `table` as the PLC runs it: inside the guards, the fault hold, the plausibility
    check and the output limits `generate` takes by default (models/reference.block_outputs, binary32)."""
    outputs = block_outputs(model, model_inputs(model, table), "f32", Limits.for_model(model))
    measured = np.asarray(table.columns[model.target.column], float)
    taken = np.isfinite(measured)
    error = (np.asarray(outputs[model.target.name], float) - measured)[taken]
    bits = [np.asarray(outputs[name], bool) for name in outputs if name.startswith("fault:") or name == DISAGREE]
    raised = np.flatnonzero(np.any(bits, axis=0)) if bits else np.zeros(0, int)
    return {"block_rmse": float(np.sqrt(np.mean(error ** 2))) if len(error) else None,
            "block_max_abs": float(np.max(np.abs(error))) if len(error) else None,
            "block_flagged_from_call": int(raised[0]) + 1 if len(raised) else None}


GUARDED = ("block_rmse", "block_max_abs", "block_flagged_from_call")


def as_the_block_runs(per_run: list[dict]) -> dict:
    """The held-out runs pooled as their blocks ran them (`guarded_errors`), and the runs on which a block raised a
    fault or its plausibility bit: an input outside what the training runs saw is a fault the block holds on, not a
    value the model extrapolates to, and the model's own figure does not show it (issue 62)."""
    if not per_run or any(run.get("block_rmse") is None for run in per_run):
        return {}
    rows = sum(run["rows"] for run in per_run)
    return {"block_rmse_um": math.sqrt(sum(run["block_rmse"] ** 2 * run["rows"] for run in per_run) / rows),
            "block_max_abs_um": max(run["block_max_abs"] for run in per_run),
            "block_flagged_runs": [run["run"] for run in per_run if run["block_flagged_from_call"] is not None]}


def screened(tables: list[Table], request: FitRequest, groups: dict | None) -> Screening:
    """The runs of a campaign refused for training and those named (fitting/broken_runs.py), on the request's
    temperatures and ambient; nothing for one recording or with `keep_every_run`."""
    if len(tables) < 2 or request.keep_every_run:
        return Screening()
    return screen_runs(tables, tuple(floor_temperatures(request.temps, request.ambient)), request.target)


def _in_order(per_run: tuple[dict, ...], screening: Screening) -> list[dict]:
    """The refused runs' held-out figures in the order the screening refused them."""
    by_run = {run["run"]: run for run in per_run}
    return [by_run[judged.run] for judged in screening.refused]


def fit_held_out(tables: list[Table], request: FitRequest, folds: int | None, time_column: str = "time_s",
                 progress: Callable[[str], None] | None = None,
                 groups: dict[str, list[int]] | None = None,
                 predictions: dict | None = None, remote: Remote | None = None) -> Model:
    """`fit` with its held-out evidence: cross-validation (blocks of one recording, whole runs of a
    campaign, or the groups of the runs table), or the request's own training split when neither
    `folds` nor `groups` is given."""
    if folds or groups is not None:
        return fit_cross_validated(tables, request, folds, time_column, progress, groups, predictions, remote)
    return fit(tables, request, time_column, progress)
