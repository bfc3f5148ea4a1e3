"""Fitting a model from a table: pick the training rows, fit, measure, package as a model file."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.base.identifiers import block_identifier, check_unique, identifier_problem
from thermoplc.base.values import UNIX_SECONDS, name_problem, names_problem, number_problem
from thermoplc.fitting import sensor_choice
from thermoplc.models.kind import Part
from thermoplc.models.kinds import kind_of, options, registry
from thermoplc.models.model import Model, Signal
from thermoplc.models.reference import model_inputs, predict
from thermoplc.fitting.envelope_fit import measure_envelope
from thermoplc.fitting.plausibility_fit import fit_plausibility
from thermoplc.fitting.start_fit import fit_start
from thermoplc.fitting.leaks import refuse_leaks, refuse_non_temperatures
from thermoplc.recordings.table import Table

SAMPLING_TOLERANCE = 0.05  # relative deviation of a time step from the median step
# (content digest, column, target, training rows, option) that passed the input checks: cross-validation
# fits every run again in each fold, and the checks (a copy of the target, a temperature range) depend
# on the data alone
_CHECKED: set[tuple] = set()


@dataclass(frozen=True)
class FitRequest:
    """What to fit: the kind, the columns, the training part; each kind's own options in `settings` by field
    (models/kind.py::KindOption: `--bins` is "bins"), an option not given being its record's default."""
    kind: str
    target: str
    temps: tuple[str, ...]
    speed: str | None = None
    ambient: str | None = None
    train_until: float | None = None
    train_rows: int | None = None
    block_name: str = "ThermalComp"
    extra_targets: tuple[str, ...] = ()  # further targets (bpnn: elongation, yaw, pitch, the compensation's order)
    choose_sensors: int = 0  # at most this many of `temps` chosen on the training rows (fitting/sensor_choice.py)
    # held as sorted (field, value) pairs of the options given other than their defaults: a request stays
    # hashable, and equal whether a default is spelled out or not
    settings: Mapping[str, Any] | tuple[tuple[str, Any], ...] = ()
    keep_every_run: bool = False  # train on every run of a campaign, broken or not (fitting/broken_runs.py)

    def __post_init__(self) -> None:
        for name in ("temps", "extra_targets"):  # a list is taken as the tuple it means (a request is hashable)
            if isinstance(getattr(self, name), list):
                object.__setattr__(self, name, tuple(getattr(self, name)))
        problem = request_problem(self)
        if problem:
            raise UserError(problem)
        declared = options()
        given = dict(self.settings)
        for name in given:
            if name not in declared:
                raise UserError(f"fit option {name!r}: no kind reads it; the kinds' options are {', '.join(declared)}")
        for name, value in given.items():
            if why := declared[name].problem(value):
                raise UserError(f"{declared[name].flag}: {why}")
        kept = {name: value for name, value in given.items() if value != declared[name].default}
        object.__setattr__(self, "settings", tuple(sorted(kept.items(), key=lambda item: item[0])))

    def option(self, name: str) -> Any:
        """A kind's own option as given, else its record's default."""
        return dict(self.settings).get(name, options()[name].default)


def request_problem(request: FitRequest) -> str | None:
    """What is wrong with a request's own fields, in the command line's words (base/values.py), or None: the
    API takes what the command line takes, and refuses the rest in one line, not a TypeError later."""
    from thermoplc.models.kinds import names
    if request.kind not in (*names(), "auto"):
        return f"--model: expected one of {', '.join((*names(), 'auto'))}, found {request.kind!r}"
    checks = {"--target": name_problem(request.target), "--temps": names_problem(request.temps),
              "--speed": name_problem(request.speed, optional=True),
              "--ambient": name_problem(request.ambient, optional=True),
              "--train-until": None if request.train_until in (None, math.inf) else  # inf: every row
              number_problem(request.train_until, float, -UNIX_SECONDS, UNIX_SECONDS, "seconds"),
              "--train-rows": None if request.train_rows is None else
              number_problem(request.train_rows, int, 1, 10 ** 9, "a row count"),
              "--choose-sensors": number_problem(request.choose_sensors, int, 0, 64, "a sensor count"),
              "--name": None if isinstance(request.block_name, str) else
              f"expected a block name, found {request.block_name!r}",
              "extra_targets": names_problem(request.extra_targets) if request.extra_targets else None}
    if not isinstance(request.settings, (Mapping, tuple, list)):
        return f"settings: expected a mapping of option to value, found {request.settings!r}"
    return next((f"{flag}: {problem}" for flag, problem in checks.items() if problem), None)


def training_rows(table: Table, time_column: str, until: float | None, rows: int | None) -> int:
    """How many leading rows train: `rows`, or those timed at or before `until` s; refuses both or neither
    given, fewer than 10, or more than the table has."""
    if (until is None) == (rows is None):
        raise UserError("give exactly one of --train-until SECONDS and --train-rows N")
    if rows is None:
        rows = int(np.searchsorted(table.columns[time_column], until, side="right"))
    if table.rows < 10:
        raise UserError(f"{table.path}: {table.rows} data row{'s' if table.rows != 1 else ''}; a fit needs at least 10")
    if rows > table.rows:
        asked = f"--train-rows {rows}" if until is None else f"--train-until {until:.12g}"
        raise UserError(f"{table.path}: {asked} asks for {rows} training rows; the file has {table.rows}")
    if rows < 10:
        asked = f"--train-rows {rows}" if until is None else f"--train-until {until:.12g} (time starts at {table.columns[time_column][0]:.12g} s)"
        raise UserError(f"{table.path}: {asked} gives {rows} training rows; a fit needs at least 10")
    return rows


def sample_period(table: Table, time_column: str, cycle: str = "SECONDS") -> float:
    """The table's sample period in s, the median time step; refuses fewer than two rows or any step more
    than 5 % off it (the block runs on a fixed cycle), naming `cycle` for --resample."""
    t = table.columns[time_column]
    if len(t) < 2:
        raise UserError(f"{table.path}: need at least two rows to know the sample period")
    steps = np.diff(t)
    dt = float(np.median(steps))
    bad = np.nonzero(np.abs(steps - dt) > SAMPLING_TOLERANCE * dt)[0]
    if len(bad):
        at = bad[0]
        dropped = (" (--gaps drop dropped the rows between)" if table.reading.gaps == "drop"
                   and table.lines[at + 1] - table.lines[at] > 1 else "")
        raise UserError(f"{table.path}:{table.lines[at + 1]}: column {time_column!r}: step {steps[at]:g} s{dropped}, "
                        f"expected {dt:g} s ±{SAMPLING_TOLERANCE:.0%}; the block runs on a fixed cycle: give --resample "
                        f"{cycle} (the block's cycle) to take the data onto it")
    return dt


def runs_named(tables: list[Table]) -> str:
    """The recordings a message is about: the path of one, the count, first and last of a campaign."""
    if len(tables) <= 2:
        return ", ".join(t.path for t in tables)
    return f"{len(tables)} runs ({tables[0].path} .. {tables[-1].path})"


def _metrics(residual: np.ndarray) -> dict:
    if not len(residual):
        return {"rows": 0, "rmse_um": None, "max_abs_um": None}
    return {"rows": int(len(residual)), "rmse_um": float(np.sqrt(np.mean(residual ** 2))),
            "max_abs_um": float(np.max(np.abs(residual)))}



def _refuse_misplaced_temps(request: FitRequest, time_column: str) -> None:
    """A --temps column that is no candidate temperature, named for what it is: given twice, the target,
    the time or an input of another role."""
    if not request.temps:
        raise UserError("--temps needs at least one column")
    twice = next((c for k, c in enumerate(request.temps) if c in request.temps[:k]), None)
    if twice is not None:
        raise UserError(f"--temps: column {twice!r} is given twice; name each sensor once")
    roles = {request.target: "the target (--target): a thermal model explains it from temperatures",
             **{extra: "a target (a further --target): a thermal model explains it from temperatures"
                for extra in request.extra_targets},
             time_column: "the time column (--time): the block runs on a fixed cycle, time is no input",
             request.speed: "the --speed input: a speed is not a temperature"}
    for column in request.temps:
        if column in roles:
            raise UserError(f"--temps {column}: the column is {roles[column]}")


def _signals(tables: list[Table], request: FitRequest) -> list[Signal]:
    signals = [Signal(block_identifier(c, "temperature"), c, "temperature", "degC") for c in request.temps]
    for owner in registry().values():
        owned = [*((getattr(request, name), text) for name, text in owner.owns_options),
                 *((option.field in dict(request.settings), option.owned) for option in owner.options if option.owned)]
        for given, text in owned:
            if given and owner.name != request.kind:
                raise UserError(f"{text} for --model {owner.name} only")
    for option in options().values():  # an option naming a column the block reads (bpnn's --tool-length)
        if option.column and (column := request.option(option.field)):
            role, unit = option.column
            signals.append(Signal(block_identifier(column, role.replace("_", " ")), column, role, unit))
    kind = kind_of(request.kind)
    for field, _ in request.settings:  # an option the kind reads, but not beside the others given
        if why := kind.conflict(request.option, field):
            raise UserError(why)
    for role in kind.roles:
        column = getattr(request, role)
        if column is None:
            raise UserError(f"--model {request.kind} needs --{role} COLUMN")
        shared = [i for i, s in enumerate(signals) if s.column == column]
        if shared and signals[shared[0]].role != "temperature":
            raise UserError(f"--{role} {column}: the column is already the {signals[shared[0]].role} input; "
                            f"one column holds one signal")
        if shared and (role == "speed" or kind.ambient_apart):
            raise UserError(f"--{role} {column}: the column is also in --temps; "
                            + ("a speed is not a temperature" if role == "speed" else
                               f"the {request.kind} model drives each --temps sensor by the ambient and needs its "
                               f"ambient sensor apart"))
        if shared:  # e.g. the ambient sensor is also one of the regression temperatures (paper 001's T14)
            s = signals[shared[0]]
            signals[shared[0]] = Signal(s.name, s.column, f"{s.role},{role}", s.unit)
            continue
        signals.append(Signal(block_identifier(column, role), column, role, "rpm" if role == "speed" else "degC"))
    for table in tables:  # the block reads them as REAL: a cell beyond binary32 is refused with its line
        for s in signals:
            table.real_column(s.column, f"a {s.role} input")
        for column in (request.target, *request.extra_targets):
            table.real_column(column, "a target")
    return signals


def check_inputs(tables: list[Table], request: FitRequest, time_column: str, n_train: list[int]
                 ) -> tuple[list[Signal], Signal]:
    """The block's inputs and target of a request, or the UserError every kind gives for them: columns that are
    missing, misplaced, clashing as block names, no temperatures, or leaking the target on the training
    rows. `auto` asks it once for every candidate sensor before it fits anything."""
    _refuse_misplaced_temps(request, time_column)
    for column in (request.speed, request.ambient):  # named though this kind may not read it: a typo is no input
        if column is not None:
            for table in tables:
                table.column(column)
    signals = _signals(tables, request)
    target = Signal(block_identifier(request.target, "target"), request.target, "target", "um")
    named = [*signals, target]
    duplicate = check_unique([s.name for s in named] + [request.block_name])
    if duplicate:
        sources = {}
        for s in named:
            sources.setdefault(s.name.upper(), []).append(repr(s.column))
        clash = next((columns for columns in sources.values() if len(columns) > 1), None)
        raise UserError(f"columns {' and '.join(clash)} become the same block name: {duplicate}; rename one"
                        if clash else f"column names clash in the block: {duplicate}")
    problem = identifier_problem(request.block_name)
    if problem:
        raise UserError(f"block name {request.block_name!r} {problem}")
    for table, n in zip(tables, n_train):
        measured = int(np.count_nonzero(np.isfinite(table.columns[request.target][:n])))
        if measured < 2:
            raise UserError(f"{table.path}: the target {request.target!r} is measured on {measured} of the "
                            f"{n} training rows (an empty cell is no measurement; with --held-target only a change "
                            f"is one); a fit needs at least 2 measurements per run")
        for s in signals:
            option = "--" + s.role.split(",")[-1].replace("temperature", "temps").replace("_", "-")
            if (table.sha256, s.column, request.target, n, option) in _CHECKED:
                continue  # a fold's fit: the same run, the same part, already checked
            if s.unit == "degC":
                refuse_non_temperatures(table, [s.column], option)
            refuse_leaks({s.column: table.columns[s.column][:n]}, request.target, table.columns[request.target][:n],
                         table.path, option)
            _CHECKED.add((table.sha256, s.column, request.target, n, option))
    return signals, target


def common_sample_period(tables: list[Table], time_column: str) -> float:
    """The runs' one sample period (the first run's); a run sampled at another is refused."""
    periods = [sample_period(t, time_column) for t in tables]
    for table, period in zip(tables, periods):
        if abs(period - periods[0]) > SAMPLING_TOLERANCE * periods[0]:
            raise UserError(f"{table.path}: sampled every {period:g} s, but {tables[0].path} every {periods[0]:g} s; "
                            f"the block has one sample period")
    return periods[0]


def fit(tables: list[Table], request: FitRequest, time_column: str = "time_s",
        progress: Callable[[str], None] | None = None) -> Model:
    """Fit `request.kind` on the training part of each run (one table per run, one part each): every kind
    takes its rises, lags, sums and filter states from each run's first row, as a freshly started block."""
    kind = kind_of(request.kind)
    n_train = [training_rows(t, time_column, request.train_until, request.train_rows) for t in tables]
    signals, target = check_inputs(tables, request, time_column, n_train)
    choice = None
    if request.choose_sensors:  # every candidate checked above; the block reads the chosen ones
        choice = choose_sensors(tables, request, n_train)
        request = replace(request, temps=choice.chosen)
        signals, target = check_inputs(tables, request, time_column, n_train)
    dt = common_sample_period(tables, time_column)
    parts = [Part(np.column_stack([t.columns[c] for c in request.temps])[:n], t.columns[request.target][:n],
                  np.column_stack([t.columns[c] for c in request.extra_targets])[:n] if request.extra_targets
                  else np.empty((n, 0)),
                  t.columns[request.speed][:n] if request.speed in t.columns else None,
                  t.columns[request.ambient][:n] if request.ambient in t.columns else None)
             for t, n in zip(tables, n_train)]
    names = [s.name for s in signals if s.role == "temperature"]
    try:
        coefficients, settings, log = kind.fit(parts, request, names, dt, progress)
    except UserError as exc:
        raise UserError(f"{runs_named(tables)}: {exc}") from None
    if choice is not None:
        log = {**log, "sensor_choice": choice.log()}
    training = [{"file": Path(t.path).name, "sha256": t.sha256, "rows": n, "total_rows": t.rows,
                 "until_s": float(t.columns[time_column][n - 1])} for t, n in zip(tables, n_train)]
    model = Model(
        kind=request.kind, block_name=request.block_name, inputs=tuple(signals), target=target,
        time_column=time_column, sample_period_s=dt, coefficients=coefficients, settings=settings,
        training=training[0] if len(training) == 1 else {"batches": training}, fit=log, reading=tables[0].reading,
    )
    return with_evidence(model, tables, n_train)


def with_evidence(model: Model, tables: list[Table], n_train: list[int]) -> Model:
    """`model` (just fitted) with what its runs give besides the coefficients: its start and envelope
    (`restarted`) and the errors on the training and held-out rows."""
    model = restarted(model, tables, n_train)
    return replace(model, metrics=evaluate(model, tables, n_train))


def restarted(model: Model, tables: list[Table], n_train: list[int]) -> Model:
    """`model` with the known start fitted for its coefficients (training rows), the envelope the default
    limits come from (every row) and its temperatures' plausibility: a model whose coefficients change needs them
    anew."""
    model = replace(model, start=fit_start(model, tables, n_train))
    return replace(model, envelope=measure_envelope(model, tables),
                   plausibility=fit_plausibility(model, tables, n_train))


def choose_sensors(tables: list[Table], request: FitRequest, n_train: list[int]) -> sensor_choice.Choice:
    """At most `request.choose_sensors` of `request.temps`, chosen on the training rows of the runs."""
    columns = [{c: t.columns[c][:n] for c in (*request.temps, request.target)} for t, n in zip(tables, n_train)]
    try:
        return sensor_choice.choose(sensor_choice.training_rises(columns, request.target, request.temps),
                                    request.temps, request.choose_sensors)
    except UserError as exc:
        raise UserError(f"{runs_named(tables)}: {exc}") from None


def evaluate(model: Model, tables: list[Table], n_train: list[int]) -> dict:
    """Fit (training rows) and prediction (held-out rows) errors of the float64 model, and the
    float32-vs-float64 quantisation error over all rows, pooled over the tables (each replayed
    from its first row, as the block would be). A probed target counts its measured rows only; the
    rows each error was taken on are `rows`, the calls they span `calls`; `start`: the error at each run's first
    measured row, the largest over the runs (what the block outputs after power-on or Reset, models/start.py)."""
    train, held_out, zero, quantisation, calls, starts = [], [], [], 0.0, [0, 0], []
    for table, n in zip(tables, n_train):
        inputs = model_inputs(model, table)
        ideal = predict(model, inputs, "f64")[model.target.name]
        block = predict(model, inputs, "f32")[model.target.name]
        measured = table.columns[model.target.column]
        residual = measured - ideal
        taken = np.isfinite(measured)
        if taken.any():
            starts.append(float(abs(residual[np.argmax(taken)])))
        train.append(residual[:n][taken[:n]])
        held_out.append(residual[n:][taken[n:]])
        zero.append(measured[n:][taken[n:]])
        calls = [calls[0] + n, calls[1] + table.rows - n]
        quantisation = max(quantisation, float(np.max(np.abs(block.astype(np.float64) - ideal))))
    held = _metrics(np.concatenate(held_out))
    if held["rows"]:
        nothing = _metrics(np.concatenate(zero))  # the error of compensating nothing
        held["zero_rmse_um"], held["zero_max_abs_um"] = nothing["rmse_um"], nothing["max_abs_um"]
    trained = _metrics(np.concatenate(train))
    for section, spanned in ((trained, calls[0]), (held, calls[1])):
        if section["rows"] != spanned:  # a probed target: measurements among the calls
            section["calls"] = spanned
    start = {"runs": len(starts), "max_abs_um": max(starts)} if starts else {"runs": 0, "max_abs_um": None}
    return {"train": trained, "held_out": held, "start": start, "float32_vs_float64_max_um": quantisation}
