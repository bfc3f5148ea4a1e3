"""The library's `fit`: the model file `thermoplc fit` writes, from runs already read and a request, so the command
line and a user's script (thermoplc.api.fit) write the same bytes. One kind is fitted with its held-out evidence
(the training split, cross-validation over blocks, runs or groups); `auto` ranks every kind and keeps the best with
the ranking; a fused block gets its probe fusion; the resample rule is recorded; a model no block can be made of
is refused before anything is written."""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.base.values import cycle_problem, number_problem
from thermoplc.fitting.auto import Candidate, Probing, rank
from thermoplc.fitting.crossval import Remote, fit_held_out
from thermoplc.fitting.fit import FitRequest, training_rows
from thermoplc.fitting.probe_fit import fit_probe
from thermoplc.generator.lower import lower_model
from thermoplc.generator.stats import block_stats
from thermoplc.models.model import Model
from thermoplc.pipeline import becomes_block
from thermoplc.recordings.resample import Resampling
from thermoplc.recordings.table import Table


@dataclass(frozen=True)
class FitPlan:
    """How a fit is judged and what its block does beside the model: what `fit`'s options add to the request,
    each checked as the command line checks it."""
    folds: int | None = None  # --folds: K blocks of one recording, or K folds of whole runs
    groups: Mapping[str, Sequence[int]] | None = None  # --group-by: run indices by group, one group left out at a time
    probe: bool = False  # --probe: a fused block, its fusion chosen on the held-out predictions
    probe_every: int | None = None  # --probe-every in calls: a probing every N calls on a target measured at each
    probe_gate_um: float | None = None  # --probe-gate-um
    held_target: bool = False  # --held-target: the target holds its last probing
    resample_s: float | None = None  # --resample: the block's cycle the runs are taken onto, the speed held

    def __post_init__(self) -> None:
        problem = _field_problem(self)
        if problem:
            raise UserError(problem)
        if self.groups is not None:  # a copy, in the order given, as Campaign.groups builds it
            object.__setattr__(self, "groups", {str(k): [int(i) for i in v] for k, v in self.groups.items()})

    @property
    def probing(self) -> Probing | None:
        return Probing(self.probe_every, self.held_target, self.probe_gate_um) if self.probe else None

    def resampling(self, request: FitRequest) -> Resampling | None:
        """The rule the model file records: the runs on the block's cycle, the speed held at its last value."""
        return Resampling.holding(self.resample_s, (request.speed,))


def _field_problem(plan: FitPlan) -> str | None:
    """Why a field is not what the command line's option takes, in its words (base/values.py), or None."""
    flags = {"--probe": plan.probe, "--held-target": plan.held_target}
    for flag, value in flags.items():
        if not isinstance(value, bool):
            return f"{flag}: expected True or False, found {value!r}"
    groups = plan.groups
    checks = {
        "--folds": None if plan.folds is None else number_problem(plan.folds, int, 2, 1_000_000, "folds"),
        "--probe-every": None if plan.probe_every is None else  # a duration may give more calls than one types
        number_problem(plan.probe_every, int, 1, 2 ** 62, "a number of calls"),
        "--probe-gate-um": None if plan.probe_gate_um is None else
        number_problem(plan.probe_gate_um, float, 0.1, 1e5, "um"),
        "--resample": None if plan.resample_s is None else cycle_problem(plan.resample_s),
        "--group-by": None if groups is None else
        None if isinstance(groups, Mapping) and all(
            isinstance(v, Sequence | np.ndarray) and not isinstance(v, str) and all(
                isinstance(i, int | np.integer) and not isinstance(i, bool | np.bool_) for i in v)
            for v in groups.values())
        else f"expected a mapping of group to run indices (Campaign.groups), found {groups!r:.60}"}
    return next((f"{flag}: {problem}" for flag, problem in checks.items() if problem), None)


def request_problem(request: FitRequest, plan: FitPlan) -> str | None:
    """What the request and the plan cannot mean together, before any run is read, in the command line's words."""
    parts = {"--train-until": request.train_until, "--train-rows": request.train_rows, "--folds": plan.folds,
             "--group-by": plan.groups}
    if sum(value is not None for value in parts.values()) != 1:  # the command line's parser allows one
        given = [flag for flag, value in parts.items() if value is not None]
        return (f"the training part: give exactly one of {', '.join(parts)} (FitRequest.train_until, train_rows; "
                f"FitPlan.folds, groups), found {' and '.join(given) if given else 'none'}")
    if request.choose_sensors and request.kind == "auto":
        return "--choose-sensors is for one kind: --model auto chooses its sensor sets itself"
    if plan.probe_every is not None and not plan.probe:
        return "--probe-every sets the probing schedule of a fused block; give --probe"
    if plan.probe_gate_um is not None and not plan.probe:
        return "--probe-gate-um sets the gate of a fused block; give --probe"
    return None


def runs_problem(request: FitRequest, plan: FitPlan, runs: int) -> str | None:
    """What the plan cannot do with this many runs, in the command line's words."""
    cross = plan.folds or plan.groups is not None
    if request.keep_every_run and not (runs > 1 and cross):
        return ("--keep-every-run keeps a campaign's runs that disagree with the others in its cross-validation; give "
                "several runs with --folds K or --group-by")
    if plan.probe and runs == 1 and cross:
        return ("--probe on one recording chooses the fusion on its held-out part: give --train-until or --train-rows "
                "instead of --folds (or a campaign of runs with --folds)")
    if plan.probe and runs > 1 and not cross:
        return "--probe on a campaign chooses the fusion on runs held out: give --folds K or --group-by"
    return None


def groups_problem(plan: FitPlan, runs: int) -> str | None:
    """Why the groups are not a partition of the runs (each run in exactly one group), or None; a runs table's
    column gives one by construction (Campaign.groups). One group for every run is refused by the folds."""
    if plan.groups is None:
        return None
    if empty := [group for group, run_indices in plan.groups.items() if not run_indices]:
        return f"--group-by: group {empty[0]!r} has no run; expected every group to hold at least one"
    indices = sorted(i for run_indices in plan.groups.values() for i in run_indices)
    if indices != list(range(runs)):
        return (f"--group-by: groups of runs {indices}; expected each of the {runs} runs (0 to {runs - 1}) in exactly "
                f"one group")
    return None


@dataclass(frozen=True)
class Fitted:
    """A fit's model with what the command prints and reports beside it."""
    model: Model
    predictions: dict = field(default_factory=dict)  # each run's held-out prediction (the report draws it)
    ranked: tuple[Candidate, ...] = ()  # `auto`'s candidates, best first
    operations: dict[int, int] = field(default_factory=dict)  # arithmetic per call of each ranked model, by position


def fit(tables: list[Table], request: FitRequest, time_column: str = "time_s", plan: FitPlan = FitPlan(),
        progress: Callable[[str], None] | None = None, remote: Remote | None = None,
        output: str = "model") -> Fitted:
    """The checked model of `request` on `tables` (one per run, each from its first row) as `plan` judges it;
    `output` names the file in a refusal. `remote` fits the folds on a cluster (the same bytes)."""
    refuse_plan(request, plan, len(tables))
    if len(tables) == 1 and not (plan.folds or plan.groups is not None):
        refuse_nothing_held_out(tables[0], request, time_column)
    if request.kind == "auto":
        fitted = _ranked(tables, request, time_column, plan, progress, remote)
    else:
        predictions: dict = {}
        model = fit_held_out(tables, request, plan.folds, time_column, progress, plan.groups, predictions, remote)
        if plan.probing is not None:  # auto fused every candidate it ranked
            model = fit_probe(model, tables, predictions, plan.probing.every, plan.probing.held,
                              plan.probing.gate_um)
        fitted = Fitted(model, predictions)
    if plan.resample_s is not None:
        fitted = replace(fitted, model=replace(fitted.model, resample=plan.resampling(request)))
    becomes_block(fitted.model, output)
    return fitted


def refuse_plan(request: FitRequest, plan: FitPlan, runs: int) -> None:
    """Every combination of the request, the plan and the runs the command line refuses, refused in its words."""
    for problem in (request_problem(request, plan), runs_problem(request, plan, runs), groups_problem(plan, runs)):
        if problem:
            raise UserError(problem)


def refuse_nothing_held_out(table: Table, request: FitRequest, time_column: str) -> None:
    """One recording whose training part takes every row leaves no evidence: name where the data end instead of
    writing a model generate will refuse (a campaign trained on whole runs is verified on other runs)."""
    if training_rows(table, time_column, request.train_until, request.train_rows) < table.rows:
        return
    if request.train_rows is not None:
        raise UserError(f"{table.path}: --train-rows {request.train_rows} leaves no row held out (the file has "
                        f"{table.rows} rows); train on fewer, or judge by cross-validation with --folds K")
    t = table.columns[time_column]
    raise UserError(f"{table.path}: --train-until {request.train_until:.12g} leaves no row held out (the data run "
                    f"from {t[0]:.12g} s to {t[-1]:.12g} s); give a time before {t[-1]:.12g} s, or judge by "
                    f"cross-validation with --folds K")


def _ranked(tables, request, time_column, plan, progress, remote) -> Fitted:
    """Every kind ranked (fitting/auto.py), the best with the ranking and each candidate's cost on the PLC."""
    ranked = tuple(rank(tables, request, plan.folds, time_column, say=progress, groups=plan.groups, remote=remote,
                        probing=plan.probing))
    operations = {k: block_stats(lower_model(c.model))["arithmetic_per_call"] for k, c in enumerate(ranked)
                  if c.model is not None}
    if not operations:
        raise UserError("--model auto: no kind could be fitted: " + "; ".join(f"{c.kind} ({c.refused})"
                                                                               for c in ranked))
    ranking = [_entry(c, operations.get(k), plan.probing is not None) for k, c in enumerate(ranked)]
    best = ranked[min(operations)].model
    return Fitted(replace(best, metrics={**best.metrics, "auto_ranking": ranking}), {}, ranked, operations)


def _entry(c: Candidate, operations: int | None, fused: bool) -> dict:
    """A candidate as the model file's metrics.auto_ranking records it."""
    options = {"options": {flag: value for flag, value in c.options}} if c.options else {}
    if c.model is None:
        return {"kind": c.kind, "sensors": list(c.sensors), **options, "refused": c.refused}
    held = c.model.metrics["held_out"]
    return {"kind": c.kind, "sensors": list(c.sensors), **options, "rmse_um": held["rmse_um"],
            "max_abs_um": held["max_abs_um"], "operations_per_call": operations, "generate_refuses": c.not_accepted,
            **({"fused_rmse_um": c.rmse} if fused else {})}
