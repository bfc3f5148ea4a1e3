"""What the recorded runs spanned, and the safety limits a block takes from them by default (issue 61).

A clamp of +-300 um and a speed guard of +-100,000 rpm fit every machine and so protect none: FL_THERMAL's
largest drift is 71 um. `fit` therefore records the envelope of the runs it was given (every row, held-out
ones too: fitting/envelope_fit.py says why) — the largest |drift| and the fastest change per call, each as
measured and as the fitted model computes it (every output, the derived ones too), and the largest |speed| —
and `generate` takes its default limits from it:

    clamp      = round_up(MARGIN * max(measured, model) largest |drift|)
    rate limit = round_up(MARGIN * measured fastest change per call)   (the model's when none was measured)
    speed      = round_up(MARGIN * largest |speed|)

rounded up to two significant digits, so the header shows a number an engineer can check by eye. The clamp
takes the model's own values too, so that it never cuts what the model did on the recording it was accepted
on; the measured ones so that a model too timid there is not clamped below the machine's drift. The rate
limit is the machine's alone: heat moves a spindle by at most so much per call, and a model that moves faster
(FL_THERMAL's mlr: 3.9 um per call against 0.75 measured, its large coefficients amplifying the sensors'
noise) is passing noise or a failing sensor on. `generate --max-offset-um`, `--max-step-um` and
`--max-speed-rpm` still set each one.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from thermoplc.base.errors import UserError
from thermoplc.models.pair import check_section

MARGIN = 1.5
SIGNIFICANT_DIGITS = 2
SMALLEST = 1e-3  # um, um per call or rpm: an extreme below this is no drift, no change or no speed (the default)
FIELDS = ("rows", "drift_um", "step_um", "speed_rpm")
LARGEST = 1e6  # um, um per call or rpm: beyond any machine (a block constant must stay a finite REAL)


@dataclass(frozen=True)
class Envelope:
    """The recorded runs' extremes over `rows` rows; drift_um and step_um as (measured, model)."""
    rows: int
    drift_um: tuple[float, float]
    step_um: tuple[float, float]
    speed_rpm: float | None  # None: the model reads no speed

    def to_doc(self) -> dict:
        pair = lambda p: {"measured": p[0], "model": p[1]}
        return {"rows": self.rows, "drift_um": pair(self.drift_um), "step_um": pair(self.step_um),
                "speed_rpm": self.speed_rpm}

    @staticmethod
    def from_doc(doc, path: str) -> "Envelope":
        """The model file's `envelope` section; every problem named by its field."""
        check_section(doc, path, "envelope", FIELDS, "part of the envelope")
        rows = doc["rows"]
        if isinstance(rows, bool) or not isinstance(rows, int) or rows < 1:
            raise UserError(f"{path}: field 'envelope.rows': {rows!r}; expected the number of rows measured, 1 or more")
        speed = doc["speed_rpm"]
        return Envelope(rows, _pair(doc["drift_um"], path, "drift_um"), _pair(doc["step_um"], path, "step_um"),
                        None if speed is None else _magnitude(speed, path, "speed_rpm"))


def _pair(doc, path: str, name: str) -> tuple[float, float]:
    if not isinstance(doc, dict) or set(doc) != {"measured", "model"}:
        raise UserError(f"{path}: field 'envelope.{name}': expected an object with measured and model")
    return _magnitude(doc["measured"], path, f"{name}.measured"), _magnitude(doc["model"], path, f"{name}.model")


def _magnitude(value, path: str, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value <= LARGEST:
        raise UserError(f"{path}: field 'envelope.{name}': {value!r}; expected a number from 0 to {LARGEST:g}")
    return float(value)


def round_up(value: float) -> float:
    """`value` (SMALLEST or more) rounded up to SIGNIFICANT_DIGITS significant digits (106.5 -> 110, 1.13 -> 1.2)."""
    if value <= 0:
        return 0.0
    unit = 10.0 ** (math.floor(math.log10(value)) - SIGNIFICANT_DIGITS + 1)
    steps = math.ceil(round(value / unit, 9))  # 0.1 * 3 (0.30000000000000004, a float's error) is 0.3, not 0.31
    return float(f"{steps * unit:.{SIGNIFICANT_DIGITS + 1}g}")


@dataclass(frozen=True)
class DataLimit:
    """One limit taken from the envelope, with the sentence that says how (the block's comment, generate's summary)."""
    value: float
    why: str


def data_limits(envelope: Envelope) -> dict[str, DataLimit]:
    """The default clamp ('max_output'), rate limit ('max_step') and speed guard ('max_speed_rpm'); a limit whose
    extreme is below SMALLEST (no drift, no change, no speed recorded) is left to the caller's default."""
    chosen = {}
    measured, model = envelope.drift_um
    if max(measured, model) >= SMALLEST:
        source = "measured" if measured >= model else "the model's"
        chosen["max_output"] = DataLimit(round_up(MARGIN * max(measured, model)),
                                         f"{MARGIN:g} x the largest |drift| recorded, {max(measured, model):.4g} "
                                         f"({source}), rounded up")
    measured, model = envelope.step_um
    if max(measured, model) >= SMALLEST:
        fastest, source = (measured, "measured") if measured >= SMALLEST else (model, "the model's: none measured")
        chosen["max_step"] = DataLimit(round_up(MARGIN * fastest),
                                       f"{MARGIN:g} x the drift's fastest change per call recorded, "
                                       f"{fastest:.4g} ({source}), rounded up")
    if envelope.speed_rpm is not None and envelope.speed_rpm >= SMALLEST:
        chosen["max_speed_rpm"] = DataLimit(round_up(MARGIN * envelope.speed_rpm),
                                            f"{MARGIN:g} x the largest |speed| recorded, "
                                            f"{envelope.speed_rpm:.6g} rpm, rounded up")
    return chosen
