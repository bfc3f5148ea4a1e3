"""What the recorded runs spanned, and the safety limits a block takes from them by default (issue 61).

A clamp of +-300 um and a speed guard of +-100,000 rpm fit every machine and so protect none: FL_THERMAL's
largest drift is 71 um. `fit` therefore records the envelope of the runs it was given (every row, held-out
ones too: fitting/envelope_fit.py says why) — the largest |drift| and the fastest change per call, each as
measured and as the fitted model computes it (every output, the derived ones too), and the largest |speed| —
and `generate` takes its default limits from it:

    clamp      = round_up(MARGIN * max(measured, model) largest |drift|)
    rate limit = round_up(MARGIN * measured fastest change per call)   (the model's when none was measured)
    speed      = round_up(MARGIN * largest |speed|)
    stuck      = max(round_up(MARGIN * longest run of repeated readings), calls in STUCK_FLOOR_S, that run + 1, 2),
                 at most STUCK_MAX; an hour of calls for a model file that does not record the run

The last: a temperature input that repeats its reading for `stuck` calls in a row is stuck (a frozen analogue
card or bus value) and sets its fault bit. A sensor read as a float moves in its last digit every call
(FL_THERMAL: never the same reading twice in a row), so the floor of 10 min decides; one read in 0.1 K steps
holds a value as long as the machine is steady (FL_THERMAL rounded to 0.1 K: up to 600 calls, 2.5 h), and the
recording, taken from the same readings, says how long that is.

rounded up to two significant digits, so the header shows a number an engineer can check by eye. The clamp
takes the model's own values too, so that it never cuts what the model did on the recording it was accepted
on; the measured ones so that a model too timid there is not clamped below the machine's drift. The rate
limit is the machine's alone: heat moves a spindle by at most so much per call, and a model that moves faster
(FL_THERMAL's mlr: 3.9 um per call against 0.75 measured, its large coefficients amplifying the sensors'
noise) is passing noise or a failing sensor on. `generate --max-offset-um`, `--max-step-um`,
`--max-speed-rpm` and `--stuck-calls` still set each one.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from thermoplc.base.errors import UserError
from thermoplc.models.pair import check_section

MARGIN = 1.5
SIGNIFICANT_DIGITS = 2
SMALLEST = 1e-3  # um, um per call or rpm: an extreme below this is no drift, no change or no speed (the default)
FIELDS = ("rows", "drift_um", "step_um", "speed_rpm")
OPTIONAL = ("same_calls",)  # a model file written before the stuck check has no same_calls
STUCK_FLOOR_S = 600.0  # a reading repeated this long is stuck however steady the recording was
STUCK_MAX = 32767  # calls: the block counts them in an INT
UNRECORDED_S = 3600.0  # the stuck time for a model file written before the envelope recorded repeated readings
LARGEST = 1e6  # um, um per call or rpm: beyond any machine (a block constant must stay a finite REAL)


@dataclass(frozen=True)
class Envelope:
    """The recorded runs' extremes over `rows` rows; drift_um and step_um as (measured, model)."""
    rows: int
    drift_um: tuple[float, float]
    step_um: tuple[float, float]
    speed_rpm: float | None  # None: the model reads no speed
    same_calls: int | None = field(default=None)  # longest run of calls a temperature input repeated its reading
    # (as a REAL); None: no temperature input, or a model file from before the stuck check

    def to_doc(self) -> dict:
        pair = lambda p: {"measured": p[0], "model": p[1]}
        return {"rows": self.rows, "drift_um": pair(self.drift_um), "step_um": pair(self.step_um),
                "speed_rpm": self.speed_rpm, **({"same_calls": self.same_calls} if self.same_calls is not None else {})}

    @staticmethod
    def from_doc(doc, path: str) -> "Envelope":
        """The model file's `envelope` section; every problem named by its field."""
        if isinstance(doc, dict) and (unknown := sorted(set(doc) - set(FIELDS) - set(OPTIONAL))):
            raise UserError(f"{path}: field 'envelope.{unknown[0]}': not part of the envelope; it has "
                            f"{', '.join((*FIELDS, *OPTIONAL))}")
        check_section({k: v for k, v in doc.items() if k not in OPTIONAL} if isinstance(doc, dict) else doc, path,
                      "envelope", FIELDS, "part of the envelope")
        rows = doc["rows"]
        if isinstance(rows, bool) or not isinstance(rows, int) or rows < 1:
            raise UserError(f"{path}: field 'envelope.rows': {rows!r}; expected the number of rows measured, 1 or more")
        same = doc.get("same_calls")
        if same is not None and (isinstance(same, bool) or not isinstance(same, int) or not 0 <= same < rows):
            raise UserError(f"{path}: field 'envelope.same_calls': {same!r}; expected the longest run of repeated "
                            f"readings, a whole number from 0 to rows - 1 ({rows - 1})")
        speed = doc["speed_rpm"]
        return Envelope(rows, _pair(doc["drift_um"], path, "drift_um"), _pair(doc["step_um"], path, "step_um"),
                        None if speed is None else _magnitude(speed, path, "speed_rpm"), same)


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


def data_limits(envelope: Envelope, sample_period_s: float) -> dict[str, DataLimit]:
    """The default clamp ('max_output'), rate limit ('max_step'), speed guard ('max_speed_rpm') and stuck-sensor
    time ('stuck_calls', calls of `sample_period_s`); a limit whose extreme is below SMALLEST (no drift, no change,
    no speed recorded) is left to the caller's default."""
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
    chosen["stuck_calls"] = stuck_limit(envelope.same_calls, sample_period_s)
    return chosen


def stuck_limit(same_calls: int | None, sample_period_s: float) -> DataLimit:
    """The stuck time from the longest run of repeated readings; for a model file that does not record it (or has no
    envelope), an hour of calls (what a steady machine read in 0.1 K steps can hold: FL_THERMAL, up to 2.5 h)."""
    calls_in = lambda seconds: math.ceil(seconds / sample_period_s - 1e-9)
    if same_calls is None:
        candidates = [(calls_in(UNRECORDED_S), f"{UNRECORDED_S / 3600:g} h of calls: the model file records no "
                                               f"repeated readings (refit to take the time from the recording)")]
    else:
        repeated = (f"no reading repeated more than {same_calls} time{'s' * (same_calls > 1)} in a row" if same_calls
                    else "no reading repeated")
        candidates = [(int(round_up(MARGIN * same_calls)) if same_calls else 0,
                       f"{MARGIN:g} x the longest run of repeated readings recorded, {same_calls}, rounded up"),
                      (calls_in(STUCK_FLOOR_S), f"{STUCK_FLOOR_S / 60:g} min of calls: {repeated} in the recording"),
                      (same_calls + 1, f"one more than the longest run of repeated readings recorded, {same_calls}")]
    calls, why = max([*candidates, (2, "the fewest repeats the check takes")], key=lambda c: c[0])
    if calls > STUCK_MAX:
        calls, why = STUCK_MAX, (f"at most {STUCK_MAX} (an INT), " + (
            f"above the longest run of repeated readings recorded, {same_calls}" if same_calls < STUCK_MAX else
            f"but the recording repeats a reading {same_calls} times in a row, so the block will flag it there; "
            f"record finer readings or give --stuck-calls"))
    return DataLimit(calls, why)
