"""Whether a fitted model has earned a block: held-out evidence that it compensates.

`verify` proves that a block computes its model; nothing there says the model helps the machine.
A model file carries the errors `fit` measured on the rows after `--train-until` (the held-out
part) beside the error of compensating nothing on the same rows. `generate` writes a block only
when that evidence exists and the model's held-out RMSE is clearly below no compensation, and
when its float32 block stays close to the float64 model it was judged as; the block header
states the evidence. Both judged on the target output, the one the model was fitted to.
"""
from __future__ import annotations

import textwrap
from dataclasses import dataclass

from thermoplc.models.modelfile import Model

CLEAR_SHARE = 0.9  # the held-out RMSE must be at most this share of no compensation's
HEADER_WIDTH = 96
QUANTISATION_SHARE = 0.1  # the float32 block may move the output by at most this share of the held-out RMSE


@dataclass(frozen=True)
class Evidence:
    """The held-out errors a model file records, in the target's unit."""
    rows: int
    rmse: float
    max_abs: float
    zero_rmse: float  # predicting 0: the error left when nothing is compensated
    zero_max_abs: float | None
    quantisation: float | None  # max |float32 block - float64 model| over the fitted recording
    unit: str
    protocol: str | None = None  # how the held-out rows were predicted, when not by the fit written

    def summary(self) -> str:
        u = self.unit
        worst = f", max |error| {self.zero_max_abs:.4g} {u}" if self.zero_max_abs is not None else ""
        how = f" ({self.protocol})" if self.protocol else ""
        return (f"{self.rows} held-out rows{how}: RMSE {self.rmse:.4g} {u}, max |error| {self.max_abs:.4g} {u}; "
                f"no compensation: RMSE {self.zero_rmse:.4g} {u}{worst}")


def evidence(model: Model) -> Evidence | None:
    """The held-out evidence in the model file, or None when it has none (no held-out rows, or a
    file written without the error of compensating nothing)."""
    held = (model.metrics or {}).get("held_out") or {}
    if not held.get("rows") or held.get("zero_rmse_um") is None:
        return None
    return Evidence(int(held["rows"]), float(held["rmse_um"]), float(held["max_abs_um"]), float(held["zero_rmse_um"]),
                    held.get("zero_max_abs_um"), (model.metrics or {}).get("float32_vs_float64_max_um"),
                    model.target.unit, held.get("protocol"))


def problem(model: Model) -> str | None:
    """Why the model has not earned a block, with the numbers; None when it has."""
    found = evidence(model)
    if found is None:
        return ("the model file carries no held-out evidence (fit with --train-until or --train-rows so rows are "
                "left to predict, and with a thermoplc that records the error of no compensation)")
    if not found.rmse <= CLEAR_SHARE * found.zero_rmse:
        return (f"{found.summary()}: not clearly better than no compensation (at most {CLEAR_SHARE:.0%} of it "
                f"is required); this block would not make the part better")
    return None


def quantisation_problem(model: Model) -> str | None:
    """Why the float32 block is not the model that was judged, or None: its output moves from the
    float64 model's by more than a share of the model's own held-out error."""
    found = evidence(model)
    if found is None or found.quantisation is None:
        return None
    if found.quantisation > QUANTISATION_SHARE * found.rmse:
        return (f"the float32 block differs from the float64 model by up to {found.quantisation:.4g} {found.unit} "
                f"on the fitted recording, more than {QUANTISATION_SHARE:.0%} of its held-out RMSE "
                f"({found.rmse:.4g} {found.unit}): the block is not the model that was judged; refit with fewer or "
                "better-conditioned inputs")
    return None


def header_lines(model: Model) -> tuple[str, ...]:
    """What the block header says of the evidence (a block without it was generated with
    --accept-unvalidated, so it says that)."""
    found, why = evidence(model), problem(model)
    text = (f"Accepted on {found.summary()}." if why is None
            else f"NOT VALIDATED - generated with --accept-unvalidated: {why}.")
    return tuple(textwrap.wrap(text, HEADER_WIDTH))
