"""What `diagnose` is asked, and the runs it reads by role: one recording split in time (its first 60 %
trains by default) or a campaign whose training runs span the hall air the held-out runs ran in (or whose
first runs train), each refused where it cannot be judged."""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.base.identifiers import identifier_problem
from thermoplc.base.values import UNIX_SECONDS, cycle_problem, name_problem, names_problem, number_problem
from thermoplc.diagnosis.parts import Parts
from thermoplc.fitting.copies import refuse_copies
from thermoplc.fitting.fit import common_sample_period, runs_named
from thermoplc.fitting.leaks import refuse_leaks, refuse_non_temperatures
from thermoplc.physics.primitives import Series
from thermoplc.recordings.campaign import Campaign
from thermoplc.recordings.reading import Reading
from thermoplc.recordings.resample import Resampling
from thermoplc.recordings.table import Table

DEFAULT_TRAIN_SHARE = 0.6
MIN_ROWS = 10
MIN_TRAIN_PROBINGS = 20  # a probed target's measurements the displacement map is fitted on
MIN_HELD_OUT_PROBINGS = 10  # ... and those every effect is judged by
MIN_AIR_SPREAD_K = 2.0  # runs whose hall air differs by this much are split by it (a designed ambient experiment)
MAX_REPEATED_SHARE = 0.5  # a target that repeats its value more often is held between probings (FL_THERMAL: 0.07 %)


@dataclass(frozen=True)
class DiagnoseRequest:
    data: tuple[str, ...] | None  # recordings or folders (--data, repeated); None with a runs table
    temps: tuple[str, ...]
    speed: str
    ambient: str
    target: str
    feed: str | None = None
    baseline: str | None = None
    train_until: float | None = None
    train_rows: int | None = None
    time_column: str = "time_s"
    block_name: str = "ThermalComp"
    reading: Reading = Reading()  # --decimal, --gaps, --time-format
    structure_lag: bool = True
    runs_table: str | None = None  # --runs TABLE
    train_runs: int | None = None  # a campaign: its first N runs train, the others are held out
    resample_s: float | None = None  # raw logger data taken onto this cycle (--resample), the speed held
    held_target: bool = False  # the target holds its last probing: only its changes are measurements

    def __post_init__(self) -> None:
        if isinstance(self.data, (list, tuple)):  # a path object is the path it names
            object.__setattr__(self, "data", tuple(os.fspath(d) if isinstance(d, os.PathLike) else d
                                                   for d in self.data))
        for name in ("baseline", "runs_table"):
            if isinstance(getattr(self, name), os.PathLike):
                object.__setattr__(self, name, os.fspath(getattr(self, name)))
        problem = request_problem(self)
        if problem:
            raise UserError(problem)
        for name in ("data", "temps"):  # a list is taken as the tuple it means (a request is hashable)
            if isinstance(getattr(self, name), list):
                object.__setattr__(self, name, tuple(getattr(self, name)))

    @property
    def resampling(self) -> Resampling | None:
        """The rule the augmented model file records (recordings/resample.py): the speed and feed held."""
        return Resampling.holding(self.resample_s, (self.speed, self.feed))


def request_problem(request: DiagnoseRequest) -> str | None:
    """What is wrong with a request's own fields, in the command line's words (base/values.py), or None."""
    optional = lambda check, value: None if value is None else check(value)
    checks = {
        "--data": optional(names_problem, request.data) and f"expected a tuple of recordings or folders, found "
                                                            f"{request.data!r}",
        "--temps": names_problem(request.temps), "--speed": name_problem(request.speed),
        "--ambient": name_problem(request.ambient), "--target": name_problem(request.target),
        "--feed": name_problem(request.feed, optional=True),
        "--baseline": None if request.baseline is None or isinstance(request.baseline, str) else
        f"expected a model file's path, found {request.baseline!r}",
        "--train-until": optional(lambda v: number_problem(v, float, -UNIX_SECONDS, UNIX_SECONDS, "seconds"), request.train_until),
        "--train-rows": optional(lambda v: number_problem(v, int, 1, 10 ** 9, "a row count"), request.train_rows),
        "--time": name_problem(request.time_column), "--runs": None if request.runs_table is None or
        isinstance(request.runs_table, str) else f"expected a runs table's path, found {request.runs_table!r}",
        "--train-runs": optional(lambda v: number_problem(v, int, 1, 10 ** 6, "a run count"), request.train_runs),
        "--resample": optional(cycle_problem, request.resample_s)}
    if request.train_until is not None and request.train_rows is not None:
        return "--train-until and --train-rows: give one of the two"
    if request.data is not None and not request.data:
        return "--data: an empty tuple; expected the recordings or folders of the runs"
    if not isinstance(request.reading, Reading):
        return f"reading: expected a thermoplc.recordings.reading.Reading, found {request.reading!r:.60}"
    naming = identifier_problem(request.block_name) if isinstance(request.block_name, str) else "is no text"
    if naming:
        return f"--name: block name {request.block_name!r} {naming}"
    for flag, value in (("structure_lag", request.structure_lag), ("--held-target", request.held_target)):
        if not isinstance(value, bool):
            return f"{flag}: expected True or False, found {value!r}"
    return next((f"{flag}: {problem}" for flag, problem in checks.items() if problem), None)


def _training_rows(table: Table, request: DiagnoseRequest) -> int:
    if request.train_rows is not None:
        rows = request.train_rows
    elif request.train_until is not None:
        rows = int(np.searchsorted(table.columns[request.time_column], request.train_until, side="right"))
    else:
        rows = int(DEFAULT_TRAIN_SHARE * table.rows)
    if rows < MIN_ROWS or table.rows - rows < MIN_ROWS:
        raise UserError(f"{table.path}: the training part has {rows} of {table.rows} rows; both it and the held-out "
                        f"part need at least {MIN_ROWS} rows (the held-out part judges every effect)")
    return rows


def series_of(table: Table, request: DiagnoseRequest, dt: float) -> Series:
    """The request's columns as a Series at period `dt` s; refuses a missing column, a --temps or --ambient
    column that is no temperature, and an input that leaks the target."""
    for column in (*request.temps, request.speed, request.ambient, request.target,
                   *((request.feed,) if request.feed else ())):
        table.column(column)
    refuse_non_temperatures(table, request.temps, "--temps")
    refuse_non_temperatures(table, [request.ambient], "--ambient")
    for option, columns in (("--temps", request.temps), ("--speed", [request.speed]), ("--ambient", [request.ambient]),
                            ("--feed", [request.feed] if request.feed else [])):
        refuse_leaks({c: table.columns[c] for c in columns}, request.target, table.columns[request.target],
                     table.path, option)
    repeated = float(np.mean(np.diff(table.columns[request.target]) == 0)) if table.rows > 2 else 0.0
    if repeated > MAX_REPEATED_SHARE:
        raise UserError(f"{table.path}: column {request.target!r}: {repeated:.0%} of its values "
                        f"repeat the one before (a drift probed and held between probings?); give --held-target "
                        f"when it holds its last probing (only its changes are measurements), or leave the cells "
                        f"between probings empty")
    return Series(dt, table.columns[request.time_column], table.columns[request.speed], table.columns[request.ambient],
                  np.column_stack([table.columns[c] for c in request.temps]), tuple(request.temps),
                  table.columns[request.target], table.columns[request.feed] if request.feed else None)


def _training_runs(campaign: Campaign, request: DiagnoseRequest) -> tuple[bool, ...]:
    """Which of a campaign's runs train: with --train-runs N its first N; else 60 % of them (at least one each
    way), the first ones, unless there are three runs or more and their hall air (each run's median) differs by
    `MIN_AIR_SPREAD_K` or more: then the coldest, the warmest and runs spread evenly between them train (at least
    two), so each held-out run lies inside the air the training runs saw (a campaign recorded at set air levels
    tests the coupling across them; holding out its coldest run would judge an extrapolation, not an effect)."""
    count = len(campaign.runs)
    if request.train_until is not None or request.train_rows is not None:
        raise UserError(f"--train-until/--train-rows split one recording; this campaign has {count} runs: give "
                        f"--train-runs N (its first N runs train, the others are held out)")
    chosen = request.train_runs if request.train_runs is not None else max(1, int(DEFAULT_TRAIN_SHARE * count))
    if not 1 <= chosen < count:
        raise UserError(f"--train-runs {chosen}: the campaign has {count} runs; both the training runs and the "
                        f"held-out runs need at least one (the held-out runs judge every effect)")
    air = [float(np.median(table.column(request.ambient))) for table in campaign.tables]
    if request.train_runs is not None or count < 3 or not np.ptp(air) >= MIN_AIR_SPREAD_K:
        return tuple(k < chosen for k in range(count))
    chosen = max(chosen, 2)  # the coldest and the warmest, a held-out run between them
    by_air = np.argsort(air, kind="stable")
    training = {int(by_air[k]) for k in np.round(np.linspace(0, count - 1, chosen)).astype(int)}
    return tuple(k in training for k in range(count))


def parts_of(campaign: Campaign, request: DiagnoseRequest) -> tuple[Parts, float]:
    """The runs by role and which rows of each train, and their common sample period: one recording split in
    time (--train-until/--train-rows, default its first 60 %), or a campaign's training runs (`_training_runs`)."""
    tables = campaign.tables
    dt = common_sample_period(tables, request.time_column)
    if request.train_runs is not None and len(tables) == 1:
        raise UserError(f"--train-runs {request.train_runs}: only one run was given; split it in time with "
                        f"--train-until or --train-rows")
    refuse_copies(tables, "a run held out against its own copy is not held out",
                  (*request.temps, request.speed, request.ambient, request.target, *((request.feed,) if request.feed else ())))
    if len(tables) == 1:
        train_rows = (_training_rows(tables[0], request),)
    else:
        training = _training_runs(campaign, request)
        train_rows = tuple(t.rows if trains else 0 for t, trains in zip(tables, training))
        for table in tables:
            if table.rows < MIN_ROWS:
                raise UserError(f"{table.path}: {table.rows} rows; a run needs at least {MIN_ROWS}")
    parts = Parts(tuple(series_of(t, request, dt) for t in tables), train_rows, tuple(campaign.labels))
    refuse_few_probings(parts, request.target, runs_named(tables))
    return parts, dt


def refuse_few_probings(parts: Parts, target: str, where_from: str = "") -> None:
    """A probed target needs probings on both sides: the training part fits the displacement map on them, the
    held-out part judges every effect by them. Too few of either is refused before anything is fitted."""
    pooled = parts.joined().target
    for where, rows, needed in (("training part", pooled[:parts.n_train], MIN_TRAIN_PROBINGS),
                                ("held-out part", pooled[parts.n_train:], MIN_HELD_OUT_PROBINGS)):
        count = int(np.count_nonzero(np.isfinite(rows)))
        if count < needed:
            raise UserError(f"{where_from + ': ' if where_from else ''}column {target!r}: measured {count} time(s) "
                            f"in the {where}; diagnose needs at least {needed} probings there (the training part fits "
                            f"the displacement map on them, the held-out part judges every effect by them; an empty "
                            f"cell is no measurement, and with --held-target only a change is one)")
