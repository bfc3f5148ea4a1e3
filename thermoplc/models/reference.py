"""One entry point to every model's reference: float64 (ideal) or binary32 (what the block computes)."""
from __future__ import annotations

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.models.kinds import kind_of
from thermoplc.models import start
from thermoplc.models.model import Model
from thermoplc.models.safety import Limits, commissioned_predict
from thermoplc.recordings.table import Table, close_match

def predict(model: Model, inputs: dict, precision: str) -> dict:
    """What the model computes, by output name; REAL outputs as float32 ('f32') or float64 ('f64') arrays;
    the target from the known start (models/start.py) when the model has one."""
    return with_start(model, kind_of(model.kind).predict(model, inputs, precision), precision)


def with_start(model: Model, outputs: dict, precision: str, state=None) -> dict:
    """The kind's outputs with the target moved by the start offset (`state`: carried between chunks)."""
    if model.start is None:
        return outputs
    return {**outputs, model.target.name: start.apply(model.start, outputs[model.target.name], precision, state)}


def guarded_core(model: Model, inputs: dict, precision: str, fused_valid: dict) -> dict:
    """The model as the safety logic calls it: a kind with fused guards gets each temperature's
    per-call validity (its filter ignores a faulty sensor), every other kind held inputs."""
    kind = kind_of(model.kind)
    if kind.fused_guards:
        return with_start(model, kind.predict(model, inputs, precision, fused_valid), precision)
    return with_start(model, kind.predict(model, inputs, precision), precision)


def block_outputs(model: Model, inputs: dict, precision: str, limits: Limits, control: dict | None = None) -> dict:
    """Every output of the generated block: the model inside its input guards and output limiter,
    called with Enable and Reset as `control` gives them per call (default: enabled, never reset).
    IEEE overflow and NaN are part of the reference (the replay reports where the block meets them)."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        return commissioned_predict(model, inputs, precision, limits, guarded_core, control)


def model_inputs(model: Model, table: Table, overrides: dict | None = None) -> dict:
    """Block input name -> float32 column, by the model's column names unless overridden."""
    overrides = overrides or {}
    inputs = {}
    for s in model.inputs:
        column = overrides.get(s.name, s.column)
        if column not in table.columns:
            raise UserError(f"{table.path}: no column {column!r} for model input {s.name!r} ({s.role})"
                            f"{close_match(column, table.columns)}; map it with --inputs {s.name}=COLUMN")
        inputs[s.name] = table.real_column(column, f"model input {s.name!r}")
    return inputs
