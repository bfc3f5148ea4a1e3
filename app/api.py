"""The public Python API: the five things the command line does, as functions over files and
objects. Everything else in the package is internal and may change.

    from thermoplc.api import FitRequest, fit, generate, verify, diff, read_table

    table = read_table("fl_thermal.csv")
    model = fit([table], FitRequest("mlr", target="ch3_um", temps=("t1_C", "t5_C"), train_until=86400.0))
    block = generate(model, "model.json")      # the acceptance gate, range proof and stress replay included
    Path("ThermalComp.scl").write_text(block.text)
    report = verify("ThermalComp.scl", model, table)
    assert report.ok                            # bit-exact on every call of the recording

`diff(old, new, table)` compares two blocks (a table adds their behaviour on it); `diagnose(request,
"diagnosed.json")` names the physical effects a lumped simulation misses (diagnosis/command.py).
A refusal is a `thermoplc.base.errors.UserError` whose text names the file and what was expected.
"""
from __future__ import annotations

from thermoplc.diagnosis.command import DiagnoseRequest, run as _diagnose
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.models.modelfile import Model, load_model
from thermoplc.models.safety import Limits
from thermoplc.recordings.table import Table, read_table
from thermoplc.pipeline import Generated, generate
from thermoplc.verifier.diff import BlockDiff, diff_blocks
from thermoplc.verifier.replay import Report, verify_against_model

__all__ = ["FitRequest", "fit", "generate", "verify", "diff", "diagnose", "DiagnoseRequest", "Generated",
           "Limits", "Model", "load_model", "read_table", "Table", "Report", "BlockDiff"]


def verify(block_path: str, model: Model, table: Table, model_path: str = "model", overrides: dict | None = None) -> Report:
    """Replay `table` through the block's ST and compare every output of every call, bit for bit,
    with the model's binary32 reference; also every declared constant and table with the model's."""
    return verify_against_model(str(block_path), model, model_path, table, overrides)


def diff(old_path: str, new_path: str, table: Table | None = None) -> BlockDiff:
    """What changed between two blocks: interface, header, constants, statements, and with `table`
    the first call on which their outputs differ."""
    return diff_blocks(str(old_path), str(new_path), table)


def diagnose(request: DiagnoseRequest, model_path: str, json_path: str | None = None,
             report_dir: str | None = None) -> dict:
    """Find the effects the lumped simulation misses on `request.data`, write the augmented model
    to `model_path` (and the findings to `json_path`, a report to `report_dir`); the findings."""
    return _diagnose(request, model_path, json_path, report_dir)
