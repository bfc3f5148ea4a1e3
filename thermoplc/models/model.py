"""What a fitted model is and how it is written: the kind, the signals, exact binary32 coefficients,
the settings and the evidence. Reading a file back and checking it against the kinds is
models/modelfile.py; the kinds' records name this type, so it imports no kind."""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from thermoplc.base.binary32 import f32_hex, round_f32
from thermoplc.base.errors import UserError
from thermoplc.base.version import __version__
from thermoplc.models.envelope import Envelope
from thermoplc.models.probing import Fusion
from thermoplc.models.start import Start
from thermoplc.recordings.reading import Reading
from thermoplc.recordings.resample import Resampling

if TYPE_CHECKING:  # the check reads the kinds' guards; the model only carries it
    from thermoplc.models.plausibility import Plausibility

FORMAT = "thermoplc-model"
SCHEMA_VERSION = 1
ROLES = ("temperature", "speed", "ambient", "tool_length", "feed")
COMBINED_ROLE = "temperature,ambient"  # the one signal with two roles: paper 001's ambient T14 is also a regressor


@dataclass(frozen=True)
class Coefficient:
    """A fitted value: f64 is the ideal (float64 fit), f32 the binary32 value the block uses."""
    f64: float
    f32: float

    @staticmethod
    def of(value: float) -> "Coefficient":
        return Coefficient(float(value), round_f32(float(value)))


@dataclass(frozen=True)
class Signal:
    name: str  # identifier in the block
    column: str  # CSV column
    role: str
    unit: str


@dataclass(frozen=True)
class Model:
    kind: str
    block_name: str
    inputs: tuple[Signal, ...]
    target: Signal
    time_column: str
    sample_period_s: float
    coefficients: dict  # name -> Coefficient, in block order
    settings: dict = field(default_factory=dict)
    training: dict = field(default_factory=dict)
    metrics: dict = field(default_factory=dict)
    fit: dict = field(default_factory=dict)
    probe: Fusion | None = None  # the probe fusion's constants (models/probing.py); None: a static block
    start: Start | None = None  # the known start (models/start.py); None: the model's own first value
    envelope: Envelope | None = None  # what the recorded runs spanned (models/envelope.py): the default limits
    resample: Resampling | None = None  # the rule that took raw logger data onto the cycle (recordings/resample.py)
    plausibility: "Plausibility | None" = None  # what each temperature should read from the others
    # (models/plausibility.py); None: fewer than two checked temperatures, or a file written before the check
    reading: Reading = Reading()  # how the recordings' text was read (--decimal, --gaps, --time-format): verify's default

    def signals(self, role: str) -> tuple[Signal, ...]:
        """Inputs with this role; one input may hold several roles ('temperature,ambient')."""
        return tuple(s for s in self.inputs if role in s.role.split(","))

    def coef(self, name: str, precision: str = "f32") -> float:
        if name not in self.coefficients:
            raise UserError(f"model file: coefficient {name!r} is missing; a {self.kind} model needs it "
                            f"(was the file written by another thermoplc version?)")
        return getattr(self.coefficients[name], precision)

    def to_json(self) -> str:
        return json.dumps(_document(self), indent=2) + "\n"

    def fingerprint(self) -> str:
        """Hash of everything that decides the block's behaviour (not the metrics or fit log)."""
        doc = _document(self)
        essential = {k: doc[k] for k in ("kind", "inputs", "target", "sample_period_s", "coefficients", "settings",
                                         "probe", "start", "envelope", "plausibility") if k in doc}
        return hashlib.sha256(json.dumps(essential, sort_keys=True).encode()).hexdigest()[:16]


def _document(m: Model) -> dict:
    return {
        "format": FORMAT,
        "schema_version": SCHEMA_VERSION,
        "written_by": f"thermoplc {__version__}",
        "kind": m.kind,
        "block_name": m.block_name,
        "time_column": m.time_column,
        "sample_period_s": m.sample_period_s,
        "inputs": [vars(s) for s in m.inputs],
        "target": vars(m.target),
        "coefficients": {k: {"f64": c.f64, "f32": f32_hex(c.f32)} for k, c in m.coefficients.items()},
        "settings": m.settings,
        **({"probe": m.probe.to_doc()} if m.probe is not None else {}),
        **({"start": m.start.to_doc()} if m.start is not None else {}),
        **({"envelope": m.envelope.to_doc()} if m.envelope is not None else {}),
        **({"resample": m.resample.to_doc()} if m.resample is not None else {}),
        **({"plausibility": m.plausibility.to_doc()} if m.plausibility is not None else {}),
        **({"reading": m.reading.to_doc()} if m.reading.to_doc() else {}),
        "training": m.training,
        "metrics": m.metrics,
        "fit": m.fit,
    }
