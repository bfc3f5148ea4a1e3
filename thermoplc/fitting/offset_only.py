"""The offset-only block (issue 62, item 3): a fused block that predicts 0 and learns only from its probings.

Where a machine's temperatures say little of its drift (a static part that generate refuses: worse than no
compensation on the held-out runs, or not clearly better), the plain offset reset over the static part inherits
its errors between probings, and nothing is offered. A block whose static part is 0 moves the axis only by what
the probings measured; its probings stop, it holds the last offset (fading where the fusion decays). `fit --probe`
writes it where the static part fails generate's rule and the fusion over 0, chosen like any other on the held-out
runs (nested), passes it: the linear kinds' block with every coefficient 0 (mlr, dlag: their map is then 0 at every
call, the temperatures still guarded), so `generate` and `verify` are those of the kind.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from thermoplc.models.kinds import kind_of
from thermoplc.models.model import Coefficient


OFFSET_ONLY = "0 (offset-only)"  # metrics.probing.static of the block


def zeroed(model):
    """`model` with every coefficient 0: its static part predicts 0 at every call (a linear kind)."""
    return replace(model, coefficients={name: Coefficient(0.0, 0.0) for name in model.coefficients})


def is_offset_only(model) -> bool:
    """A fused linear block whose every coefficient is 0, with the evidence of one: its probing figures were measured
    over a static part of 0 (the static column is no compensation's). A fitted model whose coefficients were zeroed by
    hand keeps its own evidence, and is judged as any other block."""
    probing = (model.metrics or {}).get("probing") or {}
    pooled = probing.get("pooled") or {} if isinstance(probing, dict) else {}
    return (model.probe is not None and kind_of(model.kind).increments is not None
            and all(c.f32 == 0.0 and c.f64 == 0.0 for c in model.coefficients.values())
            and isinstance(probing, dict) and probing.get("static") == OFFSET_ONLY
            and isinstance(pooled, dict) and pooled.get("static_before_um") == pooled.get("none_before_um"))


def as_none(metrics: dict) -> dict:
    """The static evidence of a block that predicts 0: no compensation's, fold by fold and run by run."""
    held = metrics.get("held_out", {})
    swapped = {"rmse_um": held.get("zero_rmse_um"), "max_abs_um": held.get("zero_max_abs_um")}
    runs = [{**r, "rmse": r["zero_rmse"], "max_abs": r["zero_max_abs"]} for r in metrics.get("runs", [])]
    folds = [{**f, "rmse": f["zero_rmse"], "max_abs": f["zero_max_abs"]} for f in metrics.get("cross_validation", [])]
    out = {**metrics, "held_out": {**held, **swapped}, "float32_vs_float64_max_um": 0.0}
    out["held_out"].pop("ridge_rmse_um", None)  # the floor of a static part: this block has none
    out.pop("start", None)
    if folds:
        out["cross_validation"] = folds
        out["held_out"]["fold_rmse_um"] = [min(f["rmse"] for f in folds), max(f["rmse"] for f in folds)]
    if runs:
        out["runs"] = runs
    return out


def zero_static(run):
    """A held-out run (fitting/probe_fit.ProbeRun) whose static prediction is 0."""
    return None if run is None else replace(run, static=np.zeros_like(run.static))
