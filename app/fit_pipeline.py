"""The library's `fit`: the model file `thermoplc fit` writes, from runs already read and a request, so the command
line and a user's script (thermoplc.api.fit) write the same bytes. One kind is fitted with its held-out evidence
(the training split, cross-validation over blocks, runs or groups); `auto` ranks every kind and keeps the best with
the ranking; a fused block gets its probe fusion; the resample rule is recorded; a model no block can be made of
is refused before anything is written."""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

from thermoplc.base.errors import UserError
from thermoplc.fitting.auto import Candidate, Probing, rank
from thermoplc.fitting.crossval import Remote, fit_held_out
from thermoplc.fitting.fit import FitRequest
from thermoplc.fitting.probe_fit import fit_probe
from thermoplc.generator.lower import lower_model
from thermoplc.generator.stats import block_stats
from thermoplc.models.model import Model
from thermoplc.pipeline import becomes_block
from thermoplc.recordings.resample import Resampling
from thermoplc.recordings.table import Table


@dataclass(frozen=True)
class FitPlan:
    """How a fit is judged and what its block does beside the model: what `fit`'s options add to the request."""
    folds: int | None = None  # --folds: K blocks of one recording, or K folds of whole runs
    groups: dict[str, list[int]] | None = None  # --group-by: run indices by group (Campaign.groups), one left out
    probe: bool = False  # --probe: a fused block, its fusion chosen on the held-out predictions
    probe_every: int | None = None  # --probe-every in calls: a probing every N calls on a target measured at each
    probe_gate_um: float | None = None  # --probe-gate-um
    held_target: bool = False  # --held-target: the target holds its last probing
    resampling: Resampling | None = None  # --resample: the rule the runs were read onto the block's cycle by

    @property
    def probing(self) -> Probing | None:
        return Probing(self.probe_every, self.held_target, self.probe_gate_um) if self.probe else None


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
    if request.kind == "auto":
        fitted = _ranked(tables, request, time_column, plan, progress, remote)
    else:
        predictions: dict = {}
        model = fit_held_out(tables, request, plan.folds, time_column, progress, plan.groups, predictions, remote)
        if plan.probing is not None:  # auto fused every candidate it ranked
            model = fit_probe(model, tables, predictions, plan.probing.every, plan.probing.held,
                              plan.probing.gate_um)
        fitted = Fitted(model, predictions)
    if plan.resampling is not None:
        fitted = replace(fitted, model=replace(fitted.model, resample=plan.resampling))
    becomes_block(fitted.model, output)
    return fitted


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
