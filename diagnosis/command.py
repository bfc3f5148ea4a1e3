"""`thermoplc diagnose`: read the data, run the search, write the augmented model, findings and report."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from thermoplc.diagnosis.findings import document
from thermoplc.diagnosis.search import diagnose
from thermoplc.base.errors import UserError
from thermoplc.base.fileio import REPORT_MANIFEST, check_report_folder, report_manifest, write_outputs
from thermoplc.models import identified_effects, lumped_model
from thermoplc.models.effects import definition_of
from thermoplc.models.fit import block_identifier, evaluate, sample_period
from thermoplc.models.modelfile import Model, Signal, load_model
from thermoplc.models.simulation import Series, Simulation
from thermoplc.models.leaks import refuse_leaks, refuse_non_temperatures
from thermoplc.models.table import Table, read_table
from thermoplc.pipeline import becomes_block

DEFAULT_TRAIN_SHARE = 0.6
MIN_ROWS = 10


@dataclass(frozen=True)
class DiagnoseRequest:
    data: str
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
    decimal: str = "auto"
    structure_lag: bool = True


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


def _check_baseline(model: Model, request: DiagnoseRequest, path: str) -> None:
    if model.kind != "lumped":
        raise UserError(f"{path}: --baseline needs a lumped model (written by `fit --model lumped` or by diagnose), "
                        f"found kind {model.kind!r}")
    expected = {"temperature": list(request.temps), "speed": [request.speed], "ambient": [request.ambient]}
    for role, columns in expected.items():
        found = [s.column for s in model.signals(role)]
        if found != columns:
            raise UserError(f"{path}: the baseline's {role} columns are {', '.join(found)}, but the command names "
                            f"{', '.join(columns)}; give the columns the baseline was fitted on")
    if model.target.column != request.target:
        raise UserError(f"{path}: the baseline predicts {model.target.column!r}, not --target {request.target!r}")
    readings = [name for name in lumped_model.effect_names(model) if not identified_effects.extends(name)]
    if readings and lumped_model.simulation_of(model).displacement.ridge_weight is not None:
        raise UserError(f"{path}: the baseline is an identified model (its fit log has a ridge_weight) with "
                        f"{', '.join(readings)}, which is no extension of one ({identified_effects.NOT_AN_EXTENSION})")


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
    return Series(dt, table.columns[request.time_column], table.columns[request.speed], table.columns[request.ambient],
                  np.column_stack([table.columns[c] for c in request.temps]), tuple(request.temps),
                  table.columns[request.target], table.columns[request.feed] if request.feed else None)


def augmented_model(final: Simulation, added: list[dict], request: DiagnoseRequest, table: Table, dt: float,
                    n_train: int) -> Model:
    """The model file of a fitted simulation; `added` is the evidence for each effect, kept in the fit log."""
    coefficients, settings = lumped_model.coefficients(final, dt)
    signals = [Signal(block_identifier(c, "temperature"), c, "temperature", "degC") for c in request.temps]
    signals.append(Signal(block_identifier(request.speed, "speed"), request.speed, "speed", "rpm"))
    signals.append(Signal(block_identifier(request.ambient, "ambient"), request.ambient, "ambient", "degC"))
    if any(definition_of(name).driven_by == "feed" for name, _ in final.effects):
        signals.append(Signal(block_identifier(request.feed, "feed"), request.feed, "feed", "mm/min"))
    model = Model(
        kind="lumped", block_name=request.block_name, inputs=tuple(signals),
        target=Signal(block_identifier(request.target, "target"), request.target, "target", "um"),
        time_column=request.time_column, sample_period_s=dt, coefficients=coefficients, settings=settings,
        training={"file": Path(table.path).name, "sha256": table.sha256, "rows": n_train, "total_rows": table.rows,
                  "until_s": float(table.columns[request.time_column][n_train - 1])},
        fit={"method": "thermoplc diagnose: " + (
            "identified lumped-mass model (steady-state Kalman filter on the readings, map by forward validation) "
            "with the effects the data supports as nested extensions" if final.displacement.ridge_weight is not None
            else "open-loop lumped-mass simulation with the effects the data supports"),
             **({"ridge_weight": final.displacement.ridge_weight} if final.displacement.ridge_weight is not None
                else {}), "effects": added})
    return Model(**{**model.__dict__, "metrics": evaluate(model, [table], [n_train])})


def run(request: DiagnoseRequest, model_path: str, json_path: str | None, report_dir: str | None,
        progress: Callable[[str], None] | None = None) -> dict:
    """`thermoplc diagnose`: fit and search, then write the augmented model, the findings JSON and the report
    folder when asked, all or nothing; returns the findings document."""
    table = read_table(request.data, request.time_column, decimal=request.decimal)
    dt = sample_period(table, request.time_column)
    n_train = _training_rows(table, request)
    series = series_of(table, request, dt)
    baseline = None
    if request.baseline:
        model = load_model(request.baseline)
        _check_baseline(model, request, request.baseline)
        baseline = lumped_model.simulation_of(model)
    d = diagnose(series, n_train, request.target, baseline, progress, request.structure_lag)
    model = augmented_model(d.final, d.added, request, table, dt, n_train)
    source = {"file": Path(table.path).name, "sha256": table.sha256}
    doc = document(d, series, n_train, source, model_path)
    becomes_block(model, model_path)
    outputs = [(model_path, model.to_json())]
    if json_path:
        outputs.append((json_path, json.dumps(doc, indent=2) + "\n"))
    stale = []
    if report_dir:
        from thermoplc.diagnosis.report import is_report_file, report
        files = report(doc, d, series, n_train)
        stale = [Path(report_dir) / n for n in check_report_folder(report_dir, list(files), [request.data],
                                                                   is_report_file)]
        outputs += [(Path(report_dir) / name, content) for name, content in files.items()]
        outputs.append((Path(report_dir) / REPORT_MANIFEST, report_manifest(list(files))))
    write_outputs(outputs, remove=stale)
    return doc
