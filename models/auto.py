"""`fit --model auto`: every applicable kind on a few sensor sets, ranked by held-out error.

A commissioning engineer has one recording and asks which model, which sensors, and whether it
helps. Each candidate is fitted exactly as `fit --model KIND` would fit it, with the same
held-out protocol (`--folds K` blocked cross-validation, or the `--train-until` split), so the
ranking is by error on rows the candidate never saw. Sensor sets come from paper 000's fuzzy
clustering with grey relational grades on the training rows only (`select-sensors --method
fcm-grey`), one set per number of groups up to `max_sensors`; a kind the data does not allow is
listed with its reason. The models themselves are the ordinary model files of their kinds.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

from thermoplc.errors import UserError
from thermoplc.models import crossval
from thermoplc.models.fit import FitRequest, fit, training_rows
from thermoplc.models.modelfile import ROLES_NEEDED, Model
from thermoplc.models.selection import select_sensors
from thermoplc.models.table import Table

KINDS = ("mlr", "dlag", "gm0n", "gm1n", "bayes", "bpnn", "kalman", "lumped")  # piecewise needs batches
MAX_SENSORS = 4


@dataclass(frozen=True)
class Candidate:
    kind: str
    sensors: tuple[str, ...]
    model: Model | None
    refused: str | None = None

    @property
    def rmse(self) -> float:
        return self.model.metrics["held_out"]["rmse_um"] if self.model else float("inf")


def sensor_sets(table: Table, request: FitRequest, train_rows: int, max_sensors: int) -> list[tuple[str, ...]]:
    """The candidate temperatures themselves when few, else the fcm-grey choice (one sensor per group
    of sensors that move alike) for 2..`max_sensors` groups, each set once."""
    if len(request.temps) <= 2:
        return [request.temps]
    columns = {c: table.columns[c][:train_rows] for c in request.temps}
    target = table.columns[request.target][:train_rows]
    sets = []
    for groups in range(2, min(max_sensors, len(request.temps)) + 1):
        chosen = tuple(select_sensors(columns, target, "fcm-grey", max_groups=groups).chosen)
        if chosen not in sets:
            sets.append(chosen)
    return sets


def rank(tables: list[Table], request: FitRequest, folds: int | None, time_column: str,
         max_sensors: int = MAX_SENSORS, say: Callable[[str], None] | None = None) -> list[Candidate]:
    """Every applicable kind on every sensor set, best held-out RMSE first (refusals last). Sensors
    are chosen on rows every candidate trains on: the first block with folds, else the training part."""
    train_rows = (crossval.cuts(tables[0], time_column, folds, request.speed)[0] if folds
                  else training_rows(tables[0], time_column, request.train_until, request.train_rows))
    have = {"speed": request.speed, "ambient": request.ambient}
    kinds = [k for k in KINDS if all(have[role] for role in ROLES_NEEDED[k])]
    found = []
    for sensors in sensor_sets(tables[0], request, train_rows, max_sensors):
        for kind in kinds:
            if say:
                say(f"auto: {kind} on {', '.join(sensors)}")
            wanted = replace(request, kind=kind, temps=sensors)  # the speed read or not, folds cut alike
            try:
                model = (crossval.fit_cross_validated(tables, wanted, folds, time_column) if folds
                         else fit(tables, wanted, time_column))
            except UserError as exc:
                found.append(Candidate(kind, sensors, None, _without_paths(str(exc), tables)))
                continue
            found.append(Candidate(kind, sensors, model))
    return sorted(found, key=lambda c: (c.model is None, c.rmse))


def _without_paths(text: str, tables: list[Table]) -> str:
    for table in tables:
        text = text.replace(f"{table.path}: ", "")
    return text
