"""Fitting a model from a table: pick the training rows, fit, measure, package as a model file."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from thermoplc.errors import UserError
from thermoplc.generator.identifiers import check_unique, identifier_from_column, identifier_problem
from thermoplc.models import kalman, mlr
from thermoplc.models.modelfile import Coefficient, Model, Signal
from thermoplc.models.reference import model_inputs, predict
from thermoplc.models.table import Table

SAMPLING_TOLERANCE = 0.05  # relative deviation of a time step from the median step


@dataclass(frozen=True)
class FitRequest:
    kind: str
    target: str
    temps: tuple[str, ...]
    speed: str | None = None
    ambient: str | None = None
    train_until: float | None = None
    train_rows: int | None = None
    block_name: str = "ThermalComp"
    options: kalman.FitOptions = kalman.FitOptions()


def block_identifier(column: str, what: str) -> str:
    name = identifier_from_column(column)
    problem = identifier_problem(name)
    if problem:
        raise UserError(f"{what} column {column!r} gives block name {name!r}, which {problem}; rename the column")
    return name


def training_rows(table: Table, time_column: str, until: float | None, rows: int | None) -> int:
    if (until is None) == (rows is None):
        raise UserError("give exactly one of --train-until SECONDS and --train-rows N")
    if rows is None:
        rows = int(np.searchsorted(table.columns[time_column], until, side="right"))
    if rows < 10 or rows > table.rows:
        raise UserError(f"{table.path}: the training part has {rows} rows; need at least 10 and at most {table.rows}")
    return rows


def sample_period(table: Table, time_column: str) -> float:
    t = table.columns[time_column]
    if len(t) < 2:
        raise UserError(f"{table.path}: need at least two rows to know the sample period")
    steps = np.diff(t)
    dt = float(np.median(steps))
    bad = np.nonzero(np.abs(steps - dt) > SAMPLING_TOLERANCE * dt)[0]
    if len(bad):
        raise UserError(f"{table.path}:{bad[0] + 3}: column {time_column!r}: step {steps[bad[0]]:g} s, expected "
                        f"{dt:g} s ±{SAMPLING_TOLERANCE:.0%}; the block runs on a fixed cycle, resample the data")
    return dt


def _metrics(residual: np.ndarray) -> dict:
    return {"rows": int(len(residual)), "rmse_um": float(np.sqrt(np.mean(residual ** 2))),
            "max_abs_um": float(np.max(np.abs(residual))) if len(residual) else 0.0}


def fit(table: Table, request: FitRequest, time_column: str = "time_s",
        progress: Callable[[str], None] | None = None) -> Model:
    for column in request.temps:
        table.column(column)
    if not request.temps:
        raise UserError("--temps needs at least one column")
    signals = [Signal(block_identifier(c, "temperature"), c, "temperature", "degC") for c in request.temps]
    if request.kind == "kalman":
        for role, column, unit in (("speed", request.speed, "rpm"), ("ambient", request.ambient, "degC")):
            if column is None:
                raise UserError(f"--model kalman needs --{role} COLUMN")
            table.column(column)
            signals.append(Signal(block_identifier(column, role), column, role, unit))
    target = Signal(block_identifier(request.target, "target"), request.target, "target", "um")
    table.column(request.target)
    duplicate = check_unique([s.name for s in signals] + [target.name, request.block_name])
    if duplicate:
        raise UserError(f"column names clash in the block: {duplicate}")
    problem = identifier_problem(request.block_name)
    if problem:
        raise UserError(f"block name {request.block_name!r} {problem}")
    n_train = training_rows(table, time_column, request.train_until, request.train_rows)
    dt = sample_period(table, time_column)
    temps = np.column_stack([table.columns[c] for c in request.temps])[:n_train]
    y = table.columns[request.target][:n_train]
    names = [s.name for s in signals if s.role == "temperature"]
    settings: dict = {}
    log: dict = {}
    if request.kind == "mlr":
        coefficients = {k: Coefficient.of(v) for k, v in mlr.fit_mlr(temps, y, names).items()}
        log = {"method": "least squares (eq. 11)"}
    else:
        te = table.columns[request.ambient][:n_train]
        n = table.columns[request.speed][:n_train]
        coefficients, settings, log = kalman.fit_kalman(temps, te, n, y, dt, names, request.options, progress)
    model = Model(
        kind=request.kind, block_name=request.block_name, inputs=tuple(signals), target=target,
        time_column=time_column, sample_period_s=dt, coefficients=coefficients, settings=settings,
        training={"file": Path(table.path).name, "sha256": table.sha256, "rows": n_train, "total_rows": table.rows,
                  "until_s": float(table.columns[time_column][n_train - 1])},
        fit=log,
    )
    return Model(**{**model.__dict__, "metrics": evaluate(model, table, n_train)})


def evaluate(model: Model, table: Table, n_train: int) -> dict:
    """Fit (training rows) and prediction (held-out rows) errors of the float64 model, and the
    float32-vs-float64 quantisation error over all rows."""
    inputs = model_inputs(model, table)
    measured = table.columns[model.target.column]
    ideal = predict(model, inputs, "f64")[model.target.name]
    block = predict(model, inputs, "f32")[model.target.name]
    residual = measured - ideal
    return {"train": _metrics(residual[:n_train]), "held_out": _metrics(residual[n_train:]),
            "float32_vs_float64_max_um": float(np.max(np.abs(block.astype(np.float64) - ideal)))}
