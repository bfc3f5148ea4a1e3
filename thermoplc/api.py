"""The public Python API: the six things the command line does, as functions over files and
objects. Everything else in the package is internal and may change.

    from thermoplc.api import FitRequest, fit, generate, verify, diff, read_table

    table = read_table("fl_thermal.csv")
    model = fit([table], FitRequest("mlr", target="ch3_um", temps=("t1_C", "t5_C"), train_until=86400.0))
    block = generate(model, "model.json")      # the acceptance gate, range proof and stress replay included
    Path("ThermalComp.scl").write_text(block.text)
    report = verify("ThermalComp.scl", model, table)
    assert report.ok                            # bit-exact on every call of the recording

`read_table(path, "Zeit", reading=Reading(gaps="drop", time_format="day-first"))` reads a logger export as
`fit --time Zeit --gaps drop --time-format day-first` does (a model fitted on it records how).
`testbench(block, model, table)` writes the block's test bench for the PLC itself (docs/commissioning.md).
`diff(old, new, table)` compares two blocks (a table adds their behaviour on it); `diagnose(request,
"diagnosed.json")` names the physical effects a lumped simulation misses (diagnosis/command.py).
A refusal is a `thermoplc.base.errors.UserError` whose text names the file and what was expected.
"""
from __future__ import annotations

import functools
import os
from typing import Callable

from thermoplc.base.errors import UserError
from thermoplc.diagnosis.command import DiagnoseRequest, run as _diagnose
from thermoplc.fit_pipeline import FitPlan, fit as _fit, refuse_plan
from thermoplc.fitting.fit import FitRequest
from thermoplc.generator.ir import Identity
from thermoplc.fitting.options_read import refuse_roles_not_read, refuse_settings_not_read
from thermoplc.models.modelfile import load_model
from thermoplc.models.model import Model
from thermoplc.models.safety import Limits
from thermoplc.recordings.reading import Reading
from thermoplc.recordings.campaign import onto_calls
from thermoplc.recordings.table import Table, read_table
from thermoplc.pipeline import Bench, Generated, generate as _generate, testbench as _testbench
from thermoplc.verifier.replays.diff import BlockDiff, diff_blocks
from thermoplc.verifier.replays.replay import Report, verify_against_model

__all__ = ["FitRequest", "FitPlan", "fit", "generate", "verify", "testbench", "diff", "diagnose",
           "DiagnoseRequest", "Generated",
           "Bench", "Limits", "Model", "load_model", "read_table", "Reading", "Table", "Report", "BlockDiff"]


def _expect(value, types: type | tuple[type, ...], argument: str, what: str) -> None:
    """A wrong Python type is refused in one line naming the argument, not as a TypeError deep inside."""
    if not isinstance(value, types):
        raise UserError(f"{argument}: expected {what}, found {type(value).__name__} {value!r:.60}")


PATH = (str, os.PathLike)


def fit(tables: list[Table], request: FitRequest, time_column: str = "time_s",
        progress: Callable[[str], None] | None = None, plan: FitPlan | None = None) -> Model:
    """The model `thermoplc fit` writes, byte for byte: `request.kind` (or "auto") fitted on the training part of
    each run (one Table per run as read_table reads it, each from its first row, as a freshly started block), with
    its held-out evidence and what `plan` adds (thermoplc.fit_pipeline.FitPlan: folds, groups, probe fusion, a
    held target, resample_s, which takes each table onto the block's cycle first). An option, a column role or a
    combination the command line refuses is refused in its words."""
    if isinstance(tables, Table):
        raise UserError("tables: expected a list of tables, one per run, found one Table: give [table]")
    _expect(tables, (list, tuple), "tables", "a list of tables, one per run")
    for table in tables:
        _expect(table, Table, "tables", "Table items (thermoplc.api.read_table)")
    if not tables:
        raise UserError("tables: an empty list; expected one table per run")
    _expect(request, FitRequest, "request", "a FitRequest")
    _expect(time_column, str, "time_column", "a column name")
    _expect(plan, (FitPlan, type(None)), "plan", "a FitPlan or None")
    plan = plan or FitPlan()
    for table in tables:
        table.column(time_column)  # a missing time column named with the file and its header
    refuse_settings_not_read(request)
    refuse_roles_not_read(request, "--resample" if plan.resample_s else
                          "--folds" if plan.folds and len(tables) == 1 else None)  # what reads the speed besides
    refuse_plan(request, plan, len(tables))
    targets = (request.target, *request.extra_targets)
    tables = [onto_calls(table, time_column, plan.resampling(request), targets, plan.held_target) for table in tables]
    return _fit(tables, request, time_column, plan, progress).model


@functools.wraps(_generate)
def generate(model: Model, *args, **kwargs) -> Generated:
    _expect(model, Model, "model", "a Model (thermoplc.api.fit or load_model)")
    limits = kwargs.get("limits", args[1] if len(args) > 1 else None)
    _expect(limits, (Limits, type(None)), "limits", "a Limits, or None for the model's own (Limits.for_model)")
    identity = kwargs.get("identity", args[4] if len(args) > 4 else None)
    _expect(identity, (Identity, type(None)), "identity", "a thermoplc.generator.ir.Identity or None")
    return _generate(model, *args, **kwargs)


def verify(block_path: str, model: Model, table: Table, model_path: str = "model", overrides: dict | None = None) -> Report:
    """Replay `table` through the block's ST and compare every output of every call, bit for bit,
    with the model's binary32 reference; also every declared constant and table with the model's."""
    _expect(block_path, PATH, "block_path", "the path of a block file")
    _expect(model, Model, "model", "a Model (thermoplc.api.fit or load_model)")
    _expect(table, Table, "table", "a Table (thermoplc.api.read_table)")
    _expect(overrides, (dict, type(None)), "overrides", "a dict of block input to column, or None")
    for name, column in (overrides or {}).items():
        _expect(name, str, "overrides", "block input names as keys")
        _expect(column, str, f"overrides[{name!r}]", "a column name")
    return verify_against_model(str(block_path), model, str(model_path), table, overrides)


def testbench(block_path: str, model: Model, table: Table, model_path: str = "model", first: int = 0,
              calls: int | None = None, rows_per_cycle: int = 50, tolerance: float = 0.0) -> Bench:
    """The test bench of the block for the PLC itself (what `thermoplc testbench` writes): `Bench.text` in the
    block's dialect, rows `first` (from 0) on of `table`, already run in thermoplc's interpreter
    (`Bench.counters`: Mismatches 0 for a block that verify proves bit-exact)."""
    _expect(block_path, PATH, "block_path", "the path of a block file")
    _expect(model, Model, "model", "a Model (thermoplc.api.fit or load_model)")
    _expect(table, Table, "table", "a Table (thermoplc.api.read_table)")
    for value, name in ((first, "first"), (rows_per_cycle, "rows_per_cycle")):
        _expect(value, int, name, "a whole number")
    _expect(calls, (int, type(None)), "calls", "a whole number, or None for as many as fit one download")
    _expect(tolerance, (int, float), "tolerance", "a number of micrometres (0: bit-exact)")
    if not (0 <= tolerance < float("inf")) or not 1 <= rows_per_cycle <= 1000:
        raise UserError("tolerance: expected a finite number >= 0; rows_per_cycle: 1 to 1000")
    return _testbench(str(block_path), model, str(model_path), table, first, calls, rows_per_cycle, float(tolerance))


def diff(old_path: str, new_path: str, table: Table | None = None) -> BlockDiff:
    """What changed between two blocks: interface, header, constants, statements, and with `table`
    the first call on which their outputs differ."""
    _expect(old_path, PATH, "old_path", "the path of a block file")
    _expect(new_path, PATH, "new_path", "the path of a block file")
    _expect(table, (Table, type(None)), "table", "a Table (thermoplc.api.read_table) or None")
    return diff_blocks(str(old_path), str(new_path), table)


def diagnose(request: DiagnoseRequest, model_path: str, json_path: str | None = None,
             report_dir: str | None = None) -> dict:
    """Find the effects the lumped simulation misses on `request.data`, write the augmented model
    to `model_path` (and the findings to `json_path`, a report to `report_dir`); the findings. No output
    may be a file the request reads, as on the command line."""
    _expect(request, DiagnoseRequest, "request", "a DiagnoseRequest")
    _expect(model_path, PATH, "model_path", "a file name")
    _expect(json_path, (*PATH, type(None)), "json_path", "a file name or None")
    _expect(report_dir, (*PATH, type(None)), "report_dir", "a folder name or None")
    return _diagnose(request, os.fspath(model_path), json_path and os.fspath(json_path),
                     report_dir and os.fspath(report_dir))
