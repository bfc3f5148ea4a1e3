"""One entry point to every model's reference: float64 (ideal) or binary32 (what the block computes)."""
from __future__ import annotations

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.models import bayes, bpnn, dlag, grey, kalman, lumped_model, mlr, piecewise
from thermoplc.models.modelfile import Model
from thermoplc.models.safety import CONTROL_START, Limits, commissioned_predict
from thermoplc.models.table import Table

_PREDICTORS = {"mlr": mlr.predict, "kalman": kalman.predict, "piecewise": piecewise.predict,
               "gm0n": grey.predict_gm0n, "gm1n": grey.predict_gm1n, "bayes": bayes.predict,
               "dlag": dlag.predict, "bpnn": bpnn.predict, "lumped": lumped_model.predict}


def predict(model: Model, inputs: dict, precision: str) -> dict:
    """What the model computes, by output name; REAL outputs as float32 ('f32') or float64 ('f64') arrays."""
    return _PREDICTORS[model.kind](model, inputs, precision)


def _core(model: Model, inputs: dict, precision: str, fused_valid: dict) -> dict:
    if model.kind == "kalman":
        return kalman.predict(model, inputs, precision, fused_valid)
    return predict(model, inputs, precision)


def block_outputs(model: Model, inputs: dict, precision: str, limits: Limits, control: dict | None = None) -> dict:
    """Every output of the generated block: the model inside its input guards and output limiter,
    called with Enable and Reset as `control` gives them per call (default: enabled, never reset).
    IEEE overflow and NaN are part of the reference (the replay reports where the block meets them)."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        return commissioned_predict(model, inputs, precision, limits, _core, control)


def model_inputs(model: Model, table: Table, overrides: dict | None = None) -> dict:
    """Block input name -> float32 column, by the model's column names unless overridden."""
    overrides = overrides or {}
    inputs = {}
    for s in model.inputs:
        column = overrides.get(s.name, s.column)
        if column not in table.columns:
            raise UserError(f"{table.path}: no column {column!r} for model input {s.name!r} ({s.role}); "
                            f"map it with --inputs {s.name}=COLUMN")
        inputs[s.name] = table.real_column(column, f"model input {s.name!r}")
    return inputs


def control_inputs(table: Table, overrides: dict | None = None) -> dict:
    """Enable and Reset per call from the data: a column named like the input (or mapped with
    --inputs Enable=COLUMN) holding 0 or 1; an input without a column keeps its start value."""
    overrides = overrides or {}
    control = {}
    for name in CONTROL_START:
        column = overrides.get(name, name)
        if column in table.columns:
            values = table.columns[column]
            bad = ~np.isin(values, (0.0, 1.0))
            if bad.any():
                table.refuse_cell(column, bad, f"the {name} input (BOOL)", "0 or 1")
            control[name] = values == 1.0
        elif name in overrides:
            raise UserError(f"{table.path}: no column {column!r} for block input {name!r}; the header has "
                            f"{', '.join(table.columns)}")
    return control
