"""`fit --model auto`: every applicable kind on a few sensor sets, ranked by held-out error.

A commissioning engineer has one recording and asks which model, which sensors, and whether it
helps. Each candidate is fitted exactly as `fit --model KIND` would fit it, with the same
held-out protocol (`--folds K` blocked cross-validation, or the `--train-until` split), so the
ranking is by error on rows the candidate never saw.

A campaign of runs: each kind is one candidate that chooses at most its `auto_sensors` of `--temps`
itself (`fit --choose-sensors`, fitting/sensor_choice.py), again inside every fold of whole runs
(leave one run out unless `--folds` or `--group-by` say otherwise), so the error a candidate is
ranked by is the held-out evidence of the very procedure whose model is written - nothing is
chosen on the runs that score it. A kind wins only by a lower error on runs it never saw.

One recording: sensor sets from forward selection (sensors added one at a time, each the one that lowers MLR's
held-out error most - or raises it least - up to `max_sensors`) and paper 000's fuzzy clustering with grey relational
grades on the training rows only (`select-sensors --method fcm-grey`). The sets are chosen with
the same held-out rows that rank the kinds, so the winner's error is a slightly optimistic
estimate (as for any choice among candidates by one validation). The closed-form kinds run on
every set; the iterative ones (genetic algorithm, differential evolution, likelihood search) on
the set of the best closed-form model, to keep the search near a minute. A kind the data does not
allow is listed with its reason, and a model whose block `generate` would refuse
(fitting/acceptance.py) ranks after every model it accepts. The models are the ordinary model
files of their kinds.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Callable

import numpy as np

from thermoplc.base.errors import ClusterError, UserError
from thermoplc.base import ridge
from thermoplc.fitting import acceptance, crossval
from thermoplc.fitting.copies import refuse_copies
from thermoplc.fitting.fit import FitRequest, check_inputs, runs_named, training_rows
from thermoplc.models.kind import Kind
from thermoplc.models.kinds import kind_of, options, registry
from thermoplc.models.model import Model
from thermoplc.fitting.selection import select_sensors
from thermoplc.recordings.table import Table

MAX_SENSORS = 4


@dataclass(frozen=True)
class Probing:
    """`fit --probe` with auto: each candidate fused as it would be alone (fitting/probe_fit.py), ranked fused."""
    every: int | None  # a probing every N calls on a target measured at every call; None: the target's own
    held: bool  # the target holds its last probing
    gate_um: float | None = None  # fit --probe-gate-um: the engineer's gate, else the rule of probe_fit.gate_of


@dataclass(frozen=True)
class Candidate:
    kind: str
    sensors: tuple[str, ...]
    model: Model | None
    refused: str | None = None  # why the kind could not be fitted
    not_accepted: str | None = None  # why generate would refuse the fitted model's block
    options: tuple[tuple[str, Any], ...] = ()  # (flag, value) it was fitted with beside the request's: --parents ridge

    @property
    def given(self) -> str:
        """The options of its shrunk form as the command line spells them (" --parents ridge"), or ""."""
        return "".join(f" {flag} {value}" for flag, value in self.options)

    @property
    def label(self) -> str:
        """Its sensors as the ranking shows them, with the options of its shrunk form."""
        return ",".join(self.sensors) + self.given

    @property
    def rmse(self) -> float:
        """The held-out RMSE it is ranked by: a fused candidate's with its probings (every call where the target
        is measured at every call, else just before each probing)."""
        if not self.model:
            return float("inf")
        fused = fused_rmse(self.model)
        return fused if fused is not None else self.model.metrics["held_out"]["rmse_um"]

    def order(self) -> tuple:
        return self.model is None, self.not_accepted is not None, self.rmse


def fused_rmse(model: Model) -> float | None:
    """A fused model's pooled held-out RMSE with its probings, None for a static one."""
    found = acceptance.fused_figures(model)
    return found[0]["fused"] if found is not None else None


def forward_selection(tables: list[Table], request: FitRequest, folds: int | None, time_column: str,
                      max_sensors: int, groups: dict | None = None,
                      remote: crossval.Remote | None = None) -> list[tuple[str, ...]]:
    """Sensors added one at a time, each the one that gives MLR (the cheapest kind, same protocol) the
    lowest held-out RMSE with those before it: the sets of 1..`max_sensors` sensors it passes through."""
    chosen: list[str] = []
    sets = []
    for _ in range(min(max_sensors, len(request.temps))):
        scored = []
        for column in request.temps:
            if column in chosen:
                continue
            try:
                model = crossval.fit_held_out(tables, replace(request, kind="mlr", temps=(*chosen, column)), folds,
                                              time_column, groups=groups, remote=remote)
            except ClusterError:
                raise
            except UserError:
                continue  # a flat sensor, or one that fails a fold: the next one
            scored.append((model.metrics["held_out"]["rmse_um"], request.temps.index(column), column))
        if not scored:
            break
        chosen.append(min(scored)[2])
        sets.append(tuple(chosen))
    return sets


def sensor_sets(table: Table, request: FitRequest, train_rows: int, max_sensors: int) -> list[tuple[str, ...]]:
    """The candidate temperatures themselves when few, else the fcm-grey choice (one sensor per group
    of sensors that move alike) for 2..`max_sensors` groups, each set once."""
    if len(request.temps) <= 2:
        return [request.temps]
    target = table.columns[request.target][:train_rows]
    measured = np.isfinite(target)  # a probed target: its measured rows
    columns = {c: table.columns[c][:train_rows][measured] for c in request.temps}
    target = target[measured]
    sets = []
    for groups in range(2, min(max_sensors, len(request.temps)) + 1):
        chosen = tuple(select_sensors(columns, target, "fcm-grey", max_groups=groups, option="--temps").chosen)
        if chosen not in sets:
            sets.append(chosen)
    return sets


def tried(request: FitRequest) -> list[Kind]:
    """The kinds `auto` fits: those with an `auto` way whose input roles the request gives. Closed-form
    kinds are fitted in well under a second, so tried on every sensor set; iterative ones search for
    seconds each, so only on the best set of the others; a kind without `auto` (piecewise) needs batches."""
    have = {"speed": request.speed, "ambient": request.ambient}
    return [k for k in registry().values() if k.auto and all(have[role] for role in k.roles)]


def rank(tables: list[Table], request: FitRequest, folds: int | None, time_column: str,
         max_sensors: int = MAX_SENSORS, say: Callable[[str], None] | None = None,
         groups: dict | None = None, remote: crossval.Remote | None = None,
         probing: Probing | None = None) -> list[Candidate]:
    """Every applicable kind, best first: the models generate accepts by held-out RMSE, then those it
    would refuse, then the kinds that could not be fitted.

    Sensor sets: forward selection by MLR's held-out error, and paper 000's fcm-grey choice on rows
    every candidate trains on (the first block with folds, else the training part). The closed-form
    kinds run on every set; the iterative ones on the set of the best closed-form model."""
    if len(tables) > 1 or groups is not None:  # a campaign: fcm-grey on the first run, whole
        train_rows = tables[0].rows
    elif folds:
        train_rows = crossval.cuts(tables[0], time_column, folds, request.speed)[0]
    else:
        train_rows = training_rows(tables[0], time_column, request.train_until, request.train_rows)
    kinds = tried(request)
    rows = [train_rows] + [t.rows for t in tables[1:]]
    check_inputs(tables, replace(request, kind="mlr"), time_column, rows)  # what every kind refuses, up front
    refuse_copies(tables, "a fold predicted by a fit on its own copy is not held out", crossval.read_columns(request))
    try:  # a sensor that never moves: every kind refuses it, so auto must not quietly leave it out
        ridge.refuse_flat(np.vstack([np.column_stack([t.columns[c][:n] for c in request.temps])
                                     for t, n in zip(tables, rows)]), list(request.temps))
    except UserError as exc:
        raise UserError(f"{runs_named(tables)}: --temps {exc}") from None
    def shrunk(found: list[Candidate]) -> list[Candidate]:
        """Each kind that shrinks on every sensor, through one ridge (base/ridge.py; bayes by its ridge parent),
        where not tried yet: steady where a subset chosen fold by fold is luck (issue 62: 0 of 8 folds of a lathe
        campaign chose the same set)."""
        return [_candidate(tables, shrunk_request(request, kind), folds,
                           time_column, kind.name, candidates_of(kind, request), say, groups, remote, probing)
                for kind in kinds if kind.shrunk is not None
                and not any(f.kind == kind.name and not f.model.fit.get("sensor_choice") and
                            set(f.sensors) == set(candidates_of(kind, request)) and
                            all(f.model.settings.get(k) == v for k, v in kind.shrunk) for f in found if f.model)]

    if _chooses_in_folds(tables, folds, groups):  # each kind chooses its sensors inside every fold
        found = [_candidate(tables, replace(request, choose_sensors=kind.auto_sensors), folds, time_column, kind.name,
                            candidates_of(kind, request), say, groups, remote, probing) for kind in kinds]
        return sorted(found + shrunk(found), key=Candidate.order)
    if say:
        say("auto: forward selection of sensors")
    sets = forward_selection(tables, request, folds, time_column, max_sensors, remote=remote)
    seen = {frozenset(s) for s in sets}
    sets += [s for s in sensor_sets(tables[0], request, train_rows, max_sensors) if frozenset(s) not in seen]
    found = [_candidate(tables, request, folds, time_column, kind.name, sensors, say, groups, remote, probing)
             for sensors in sets for kind in kinds if kind.auto == "closed-form"]
    best_set = min(found, key=Candidate.order).sensors
    found += [_candidate(tables, request, folds, time_column, kind.name, best_set, say, groups, remote, probing)
              for kind in kinds if kind.auto == "iterative"]
    return sorted(found + shrunk(found), key=Candidate.order)


def _chooses_in_folds(tables: list[Table], folds: int | None, groups: dict | None) -> bool:
    """A campaign whose every fold trains on two runs or more: each kind chooses its sensors leaving out each
    training run. With fewer (two runs, or a group holding all runs but one) a fold's choice would rest on one
    run's last third, so such a campaign is ranked like one recording, on the sensor sets."""
    if len(tables) < 2 and groups is None:
        return False
    held = [members for _, members in crossval.run_folds(tables, folds, groups)]
    return min(len(tables) - len(members) for members in held) >= 2


def candidates_of(kind: Kind, request: FitRequest) -> tuple[str, ...]:
    """The sensors a kind may choose from: --temps, less the ambient for a kind that drives every sensor by it."""
    return tuple(c for c in request.temps if not (kind.ambient_apart and c == request.ambient))


def _candidate(tables, request, folds, time_column, kind, sensors, say, groups=None, remote=None,
               probing: Probing | None = None) -> Candidate:
    if say:
        say(f"auto: {kind} choosing at most {min(request.choose_sensors, len(sensors))} of {len(sensors)} sensors "
            f"in every fold"
            if request.choose_sensors else f"auto: {kind} on {', '.join(sensors)}")
    wanted = replace(request, kind=kind, temps=sensors)  # the speed read or not, folds cut alike
    predictions: dict = {}
    try:
        model = crossval.fit_held_out(tables, wanted, folds, time_column, groups=groups, remote=remote,
                                      predictions=predictions if probing else None)
        if probing:
            from thermoplc.fitting.probe_fit import fit_probe
            model = fit_probe(model, tables, predictions, probing.every, probing.held, probing.gate_um)
    except ClusterError:
        raise
    except UserError as exc:
        return Candidate(kind, sensors, None, _without_paths(str(exc), tables), options=_shrunk_options(wanted))
    chosen = model.fit.get("sensor_choice", {}).get("chosen", sensors)
    return Candidate(kind, tuple(chosen), model, not_accepted=acceptance.refusal(model), options=_shrunk_options(wanted))


def shrunk_request(request: FitRequest, kind: Kind) -> FitRequest:
    """The request in a kind's shrunk form: its options set, and the options given that it does not read in that
    form left out (`--bins` for bayes's ridge parent: it shapes the other bayes candidates)."""
    shrunk = dict(kind.shrunk)
    read = lambda field: shrunk.get(field, request.option(field))
    given = {field: value for field, value in request.settings if not kind.conflict(read, field)}
    return replace(request, settings={**given, **shrunk})


def _shrunk_options(request: FitRequest) -> tuple[tuple[str, Any], ...]:
    """The options a candidate was given for its shrunk form (`--parents ridge`), as the command line spells them."""
    shrunk = kind_of(request.kind).shrunk or ()
    return tuple((options()[field].flag, value) for field, value in shrunk if request.option(field) == value)


def _without_paths(text: str, tables: list[Table]) -> str:
    for named in (runs_named(tables[:k] + tables[k + 1:]) for k in range(len(tables))):
        if named:  # one table less than none is no name
            text = text.replace(f"{named}: ", "")
    for table in tables:
        text = text.replace(f"{table.path}: ", "")
    return text
