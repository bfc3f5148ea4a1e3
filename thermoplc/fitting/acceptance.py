"""Whether a fitted model has earned a block: held-out evidence that it compensates.

`verify` proves that a block computes its model; nothing there says the model helps the machine.
A model file carries the errors `fit` measured on the rows after `--train-until` (the held-out
part) beside the error of compensating nothing on the same rows. `generate` writes a block only
when that evidence exists and the model's held-out RMSE is clearly below no compensation, and
when its float32 block stays close to the float64 model it was judged as; the block header
states the evidence. Both judged on the target output, the one the model was fitted to.
"""
from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass

from thermoplc.base.errors import UserError
from thermoplc.models.model import Model

WORSE_RUNS_SHARE = 0.25  # of a campaign's held-out runs that may do worse than no compensation
MIN_HELD_OUT_ROWS = 100  # fewer predicted rows than this say nothing of a thermal model
CLEAR_SHARE = 0.9  # the held-out RMSE must be at most this share of no compensation's
HEADER_WIDTH = 96
START_TOLERANCE = 1.0  # um: a start within this of the measured drift is right whatever the held-out RMSE (runs
# that start a few tenths apart by sensor noise must not refuse a model that predicts to 0.1 um)
QUANTISATION_SHARE = 0.1  # the float32 block may move the output by at most this share of the held-out RMSE


@dataclass(frozen=True)
class Evidence:
    """The held-out errors a model file records, in the target's unit."""
    rows: int
    rmse: float
    max_abs: float
    zero_rmse: float  # predicting 0: the error left when nothing is compensated
    zero_max_abs: float | None
    quantisation: float  # max |float32 block - float64 model| over the fitted recording
    unit: str
    protocol: str | None = None  # how the held-out rows were predicted, when not by the fit written

    def summary(self) -> str:
        u = self.unit
        worst = f", max |error| {self.zero_max_abs:.4g} {u}" if self.zero_max_abs is not None else ""
        how = f" ({self.protocol})" if self.protocol else ""
        return (f"{self.rows} held-out rows{how}: RMSE {self.rmse:.4g} {u}, max |error| {self.max_abs:.4g} {u}; "
                f"no compensation: RMSE {self.zero_rmse:.4g} {u}{worst}")


def _number(value, field: str, optional: bool = False) -> float | None:
    """A finite number >= 0 from the model file's metrics, or an error naming the field."""
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
        raise UserError(f"field 'metrics.{field}' must be a finite number >= 0, found {value!r}")
    return float(value)


def _section(metrics: dict, key: str) -> dict:
    value = metrics.get(key) or {}
    if not isinstance(value, dict):
        raise UserError(f"field 'metrics.{key}' must be an object, found {type(value).__name__}")
    return value


def _rows(section: dict, key: str) -> int:
    rows = section.get("rows", 0)
    if isinstance(rows, bool) or not isinstance(rows, int) or rows < 0:
        raise UserError(f"field 'metrics.{key}.rows' must be a whole number >= 0, found {rows!r}")
    return rows


def metrics_of(model: Model) -> dict:
    """The model file's metrics, an object."""
    metrics = model.metrics or {}
    if not isinstance(metrics, dict):
        raise UserError(f"field 'metrics' must be an object, found {type(metrics).__name__}")
    return metrics


def evidence(model: Model) -> Evidence | None:
    """The held-out evidence in the model file, or None when it has none (no held-out rows, or a
    file written without the error of compensating nothing); a malformed value is an error."""
    metrics = model.metrics or {}
    held = _section(metrics, "held_out")
    rows = _rows(held, "held_out")
    if not rows or held.get("zero_rmse_um") is None:
        return None
    protocol = held.get("protocol")
    if protocol is not None and not isinstance(protocol, str):
        raise UserError(f"field 'metrics.held_out.protocol' must be text, found {protocol!r}")
    return Evidence(rows, _number(held.get("rmse_um"), "held_out.rmse_um"),
                    _number(held.get("max_abs_um"), "held_out.max_abs_um"),
                    _number(held.get("zero_rmse_um"), "held_out.zero_rmse_um"),
                    _number(held.get("zero_max_abs_um"), "held_out.zero_max_abs_um", optional=True),
                    _number(metrics.get("float32_vs_float64_max_um"), "float32_vs_float64_max_um"),
                    model.target.unit, protocol)


def _worse_fold(model: Model) -> str | None:
    """A cross-validation fold in which the model did worse than no compensation. Folds of whole runs
    (a campaign) are runs of their own: a run that hardly drifted (a cold machine's short run) may come
    out a few um worse while the others gain tens, so there more than WORSE_RUNS_SHARE of the held-out
    runs doing worse refuses."""
    metrics = model.metrics or {}
    folds = metrics.get("cross_validation") or []
    if not isinstance(folds, list) or not all(isinstance(f, dict) for f in folds):
        raise UserError("field 'metrics.cross_validation' must be a list of folds")
    worse = []
    for k, fold in enumerate(folds):
        rmse = _number(fold.get("rmse"), f"cross_validation[{k}].rmse")
        zero = _number(fold.get("zero_rmse"), f"cross_validation[{k}].zero_rmse")
        if rmse > zero:
            worse.append(f"fold {fold.get('label', k + 1)}: RMSE {rmse:.4g} against {zero:.4g} with no compensation")
    runs = metrics.get("runs")
    if runs and isinstance(runs, list) and len(folds) > 1:
        bad = [r for r in runs if isinstance(r, dict) and _number(r.get("rmse"), "runs.rmse")
               > _number(r.get("zero_rmse"), "runs.zero_rmse")]
        if len(bad) > WORSE_RUNS_SHARE * len(runs):
            return (f"{len(bad)} of {len(runs)} held-out runs (more than {WORSE_RUNS_SHARE:.0%}), e.g. "
                    f"{bad[0].get('run')}: RMSE {bad[0]['rmse']:.4g} against {bad[0]['zero_rmse']:.4g}")
        return None
    return worse[0] if worse else None


def problem(model: Model) -> str | None:
    """Why the model has not earned a block, with the numbers; None when it has. An offset-only block
    (fitting/offset_only.py) predicts 0 between its probings: only its fused evidence is judged."""
    from thermoplc.fitting.offset_only import is_offset_only
    found = evidence(model)
    if found is not None and found.rows >= MIN_HELD_OUT_ROWS and is_offset_only(model):
        return _fused_problem(model)
    if found is None:
        return ("the model file carries no held-out evidence (fit with --train-until, --train-rows or --folds so rows "
                "are left to predict, and with a thermoplc that records the error of no compensation)")
    if found.rows < MIN_HELD_OUT_ROWS:
        return f"{found.summary()}: fewer than {MIN_HELD_OUT_ROWS} held-out rows are no evidence"
    if not found.rmse <= CLEAR_SHARE * found.zero_rmse:
        return (f"{found.summary()}: not clearly better than no compensation (at most {CLEAR_SHARE:.0%} of it "
                f"is required); this block would not make the part better")
    start = _section(metrics_of(model), "start")
    if start.get("max_abs_um") is not None:
        error = _number(start["max_abs_um"], "start.max_abs_um")
        if not error <= max(found.rmse, START_TOLERANCE):
            return (f"{found.summary()}, but at a run's start (first call) it is {error:.4g} {found.unit} off: more "
                    f"than its held-out RMSE and {START_TOLERANCE:g} {found.unit}; after power-on or Reset the block would move the axis the wrong way "
                    f"(refit with this thermoplc: the block then starts at the drift measured at its runs' start)")
    worse = _worse_fold(model)
    if worse:
        return f"{found.summary()}, but in {worse}: worse than no compensation in part of the recording"
    return _fused_problem(model)


def fails_to_compensate(model: Model) -> str | None:
    """Why the model's held-out evidence says it does not compensate (not clearly better than none, or worse in too
    many folds or runs), or None: no evidence, too few rows, or a model that compensates (fitting/offset_only.py
    offers its block for this failure only)."""
    found = evidence(model)
    if found is None or found.rows < MIN_HELD_OUT_ROWS:
        return None
    if not found.rmse <= CLEAR_SHARE * found.zero_rmse:
        return (f"{found.summary()}: not clearly better than no compensation (at most {CLEAR_SHARE:.0%} of it is "
                f"required)")
    worse = _worse_fold(model)
    return f"{found.summary()}, but in {worse}: worse than no compensation" if worse else None


def fused_figures(model: Model) -> tuple[dict, str] | None:
    """(fused, static and none RMSE, where they were measured) from metrics.probing, or None without them."""
    pooled = _section(_section(model.metrics or {}, "probing"), "pooled")
    if model.probe is None or pooled.get("fused_before_um") is None:
        return None
    which = "rmse" if pooled.get("fused_rmse_um") is not None else "before"
    values = {m: _number(pooled.get(f"{m}_{which}_um"), f"probing.pooled.{m}_{which}_um")
              for m in ("fused", "static", "none")}
    return values, "over every call" if which == "rmse" else "just before each probing"


def fused_summary(model: Model) -> str | None:
    """A fused block's held-out evidence with its probings (metrics.probing, pooled over the held-out runs at the
    schedule it was fitted for): every call where the target is measured at every call, else just before each
    probing; None for a static block or a file without that evidence."""
    found = fused_figures(model)
    if found is None:
        return None
    values, where = found
    u = model.target.unit
    probings = _section(_section(model.metrics, "probing"), "pooled").get("probings")
    rule = _section(_section(model.metrics, "probing"), "chosen").get("gate_rule")
    gate = f"; a probing further than {model.probe.value('gate_um', 'f64'):.4g} {u} from the prediction is refused " \
           f"({rule})" if rule and model.probe is not None else ""
    from thermoplc.fitting.offset_only import is_offset_only
    static = ("offset-only: 0 between probings" if is_offset_only(model) else
              f"static block fitted without --probe {values['static']:.4g} {u}")
    return (f"with its probings ({probings} held out), RMSE {values['fused']:.4g} {u} {where}; {static}, "
            f"no compensation {values['none']:.4g} {u}{gate}")


def _fused_problem(model: Model) -> str | None:
    """Why a fused block has not earned its fusion: no held-out evidence of it, with its probings no better
    than its static block (then the fusion only adds a state), or not clearly better than no compensation."""
    if model.probe is None:
        return None
    found = fused_figures(model)
    if found is None:
        return "the model file carries no held-out evidence of its probe fusion (fit it with --probe)"
    values = found[0]
    if not values["fused"] <= CLEAR_SHARE * values["none"]:
        return f"fused {fused_summary(model)}: not clearly better than no compensation"
    if not values["fused"] <= values["static"]:
        return f"fused {fused_summary(model)}: worse than the static block; generate it without --probe"
    return None


def quantisation_problem(model: Model) -> str | None:
    """Why the float32 block is not the model that was judged, or None: its output moves from the
    float64 model's by more than a share of the model's own error (held out, else on the training
    rows)."""
    metrics = model.metrics or {}
    train = _section(metrics, "train")
    found = evidence(model)
    if found is not None:
        error, where, drift = found.rmse, "held-out", found.quantisation
    elif _rows(train, "train"):
        error, where = _number(train.get("rmse_um"), "train.rmse_um"), "training"
        drift = _number(metrics.get("float32_vs_float64_max_um"), "float32_vs_float64_max_um")
    else:
        return None
    if drift > QUANTISATION_SHARE * error:
        unit = model.target.unit
        return (f"the float32 block differs from the float64 model by up to {drift:.4g} {unit} on the fitted "
                f"recording, more than {QUANTISATION_SHARE:.0%} of its {where} RMSE ({error:.4g} {unit}): the block "
                "is not the model that was judged; refit with fewer or better-conditioned inputs")
    return None


def refusal(model: Model) -> str | None:
    """Why `generate` refuses the model without --accept-unvalidated, or None."""
    return quantisation_problem(model) or problem(model)


def header_lines(model: Model) -> tuple[str, ...]:
    """What the block header says of the evidence (a block without it was generated with
    --accept-unvalidated, so it says that)."""
    found, why = evidence(model), problem(model)
    fused = fused_summary(model)
    text = (f"Accepted on {found.summary()}" + (f"; fused {fused}." if fused else ".") if why is None
            else f"NOT VALIDATED - generated with --accept-unvalidated: {why}.")
    return tuple(textwrap.wrap(text, HEADER_WIDTH))
