"""`thermoplc diagnose`: read the data, run the search, write the augmented model, findings and report."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Callable

import numpy as np

from thermoplc.diagnosis.findings import document
from thermoplc.diagnosis.parts import Parts
from thermoplc.diagnosis.runs import DiagnoseRequest, parts_of
from thermoplc.diagnosis.search import diagnose_runs
from thermoplc.base.errors import UserError
from thermoplc.base.fileio import REPORT_MANIFEST, check_outputs, report_manifest, write_outputs
from thermoplc.models.kinds import lumped_model
from thermoplc.recordings.campaign import read_campaign, run_list, source_of
from thermoplc.physics.effects import definition_of
from thermoplc.fitting.fit import block_identifier, with_evidence
from thermoplc.models.modelfile import load_model
from thermoplc.models.model import Model, Signal
from thermoplc.physics.fitted import Simulation
from thermoplc.recordings.table import Table
from thermoplc.pipeline import becomes_block, block_problem

PERIOD_TOLERANCE = 1e-4  # relative: time stamps far from 0 (a logger's Unix time) round each step a little


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
    if model.probe is not None:
        raise UserError(f"{path}: a fused model (fit --probe); diagnose compares the simulation with the measured "
                        f"drift and would drop the fusion: give the model fitted without --probe")
    lumped_model.check_fit_log(model, path)
    problem = block_problem(model)  # an effect listed without its coefficients is no model a block is made of
    if problem:
        raise UserError(f"{path}: --baseline is no model a block can be made of: {problem}")


def check_period(model: Model, dt: float, path: str) -> None:
    """The baseline's sample period against the data's, within PERIOD_TOLERANCE."""
    if abs(model.sample_period_s - dt) > PERIOD_TOLERANCE * model.sample_period_s:
        raise UserError(f"{path}: fitted at a sample period of {model.sample_period_s:g} s; the data are sampled "
                        f"every {dt:g} s (give --resample {model.sample_period_s:g})")


def augmented_model(final: Simulation, added: list[dict], request: DiagnoseRequest, tables: list[Table], dt: float,
                    train_rows: tuple[int, ...]) -> Model:
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
        resample=request.resampling, reading=request.reading,
        training=_training_record(tables, train_rows, request.time_column),
        fit={"method": "thermoplc diagnose: " + (
            "identified lumped-mass model (steady-state Kalman filter on the readings, map by forward validation) "
            "with the effects the data supports as nested extensions" if final.displacement.ridge_weight is not None
            else "open-loop lumped-mass simulation with the effects the data supports"),
             **({"ridge_weight": final.displacement.ridge_weight} if final.displacement.ridge_weight is not None
                else {}),
             **({"structure_lag_chosen_s": final.displacement.tau_struct_chosen_s}
                if final.displacement.tau_struct_chosen_s is not None else {}), "effects": added})
    return with_evidence(model, tables, list(train_rows))


def _training_record(tables: list[Table], train_rows: tuple[int, ...], time_column: str) -> dict:
    """Which rows of which files trained: one recording's split, or every run with its role."""
    records = [{"file": Path(t.path).name, "sha256": t.sha256, "rows": n, "total_rows": t.rows,
                **({"until_s": float(t.columns[time_column][n - 1])} if n else {"held_out": True})}
               for t, n in zip(tables, train_rows)]
    return records[0] if len(records) == 1 else {"batches": records}


def _search(parts: Parts, request: DiagnoseRequest, progress, tries):
    """The search from the identified baseline, or from --baseline's model, checked against the request."""
    baseline = None
    if request.baseline:
        model = load_model(request.baseline)
        _check_baseline(model, request, request.baseline)
        check_period(model, parts.runs[0].dt, request.baseline)
        baseline = lumped_model.simulation_of(model)
        if baseline.displacement.ridge_weight is None and parts.campaign:
            raise UserError(f"{request.baseline}: an open-loop simulation an earlier diagnose fitted runs on one "
                            f"recording; for a campaign give an identified model (`fit --model lumped`) or none")
        if baseline.displacement.ridge_weight is None and not np.isfinite(parts.joined().target).all():
            raise UserError(f"{request.baseline}: an open-loop simulation an earlier diagnose fitted needs the target "
                            f"measured every call; {request.target!r} is probed: give an identified model "
                            f"(`fit --model lumped`) or none")
        readings = [name for name, _ in baseline.effects if definition_of(name).part == "reading"]
        if readings and parts.campaign:
            raise UserError(f"{request.baseline}: field 'settings.effects': {', '.join(readings)} is an error of one "
                            f"sensor's reading, fitted on one run; a campaign's runs may each start with their own")
    return diagnose_runs(parts, request.target, baseline, progress, request.structure_lag, tries)


def run(request: DiagnoseRequest, model_path: str, json_path: str | None, report_dir: str | None,
        progress: Callable[[str], None] | None = None, scheduler: str | None = None) -> dict:
    """`thermoplc diagnose`: fit and search, then write the augmented model, the findings JSON and the report
    folder when asked, all or nothing; returns the findings document. With `scheduler` (tcp://HOST:PORT) each
    round's candidates are tried on that Dask cluster's workers (diagnosis/remote.py): the same bytes."""
    runs = run_list(list(request.data) if request.data is not None else None, request.runs_table)
    inputs = [*runs.paths, *([runs.table] if runs.table else []), *([request.baseline] if request.baseline else [])]
    check_outputs({"model_path": model_path, "json_path": json_path}, True, inputs)  # never onto an input
    campaign = read_campaign(runs, request.time_column, request.reading, probed=(request.target,),
                             held=request.held_target, resampling=request.resampling)
    parts, dt = parts_of(campaign, request)
    tries = None
    if scheduler:
        from thermoplc.base.cluster import connect
        from thermoplc.diagnosis.remote import OnCluster
        read_again = source_of(campaign, runs, request.time_column, request.reading, (request.target,),
                               request.held_target, request.resampling)
        tries = OnCluster(connect(scheduler), read_again, request)
    try:
        d = _search(parts, request, progress, tries)
    finally:
        if tries is not None:
            tries.cluster.close()
    tables = campaign.tables
    model = augmented_model(d.final, d.added, request, tables, dt, parts.train_rows)
    source = ({"file": Path(tables[0].path).name, "sha256": tables[0].sha256} if len(tables) == 1 else
              {"files": [{"file": label, "sha256": t.sha256} for label, t in zip(campaign.labels, tables)],
               "given": [("--runs", request.runs_table)] if request.runs_table else
               [("--data", path) for path in request.data]})
    doc = document(d, source, model_path)
    becomes_block(model, model_path)
    outputs = [(model_path, model.to_json())]
    if json_path:
        outputs.append((json_path, json.dumps(doc, indent=2) + "\n"))
    stale = []
    if report_dir:
        from thermoplc.diagnosis.report import is_report_file, report
        files = report(doc, d)
        stale = [Path(report_dir) / n for n in check_outputs({"model_path": model_path, "json_path": json_path}, True,
                                                             inputs, report_dir, list(files), is_report_file)]
        outputs += [(Path(report_dir) / name, content) for name, content in files.items()]
        outputs.append((Path(report_dir) / REPORT_MANIFEST, report_manifest(list(files.items()))))
    write_outputs(outputs, remove=stale)
    return doc
