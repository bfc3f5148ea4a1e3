"""Paper 000's sensor errors, added to a synthetic machine's readings (`twin --sensor-fault`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thermoplc.base.errors import UserError

FAULT_KINDS = ("sin", "offset")


@dataclass(frozen=True)
class SensorFault:
    """Paper 000 eq. 18 (`sin`: +2*sin(t/350) °C) or eq. 19 (`offset`: -2 °C) from `start_s` on."""
    kind: str
    column: str
    start_s: float = 0.0

    @staticmethod
    def parse(text: str, columns: tuple[str, ...]) -> "SensorFault":
        """KIND:COLUMN[@START_S], COLUMN one of the machine's sensor `columns`."""
        spec, _, start = text.partition("@")
        kind, _, column = spec.partition(":")
        if kind not in FAULT_KINDS or column not in columns:
            raise UserError(f"--sensor-fault {text!r}: expected KIND:COLUMN[@START_S] with KIND one of "
                            f"{', '.join(FAULT_KINDS)} and COLUMN one of {', '.join(columns)}")
        try:
            start_s = float(start) if start else 0.0
        except ValueError:
            raise UserError(f"--sensor-fault {text!r}: start time {start!r} is not a number of seconds") from None
        if not np.isfinite(start_s):
            raise UserError(f"--sensor-fault {text!r}: start time must be a finite number of seconds")
        return SensorFault(kind, column, start_s)

    def describe(self) -> str:
        """What the fault adds to its column, as the twin's summary says it."""
        wave = "+2*sin(t/350 s) degC (paper 000 eq. 18)" if self.kind == "sin" else "-2 degC (paper 000 eq. 19)"
        return f"sensor fault {self.kind} on {self.column} from {self.start_s:g} s: {wave}"

    def error(self, t: np.ndarray) -> np.ndarray:
        active = t >= self.start_s
        wave = 2.0 * np.sin(t / 350.0) if self.kind == "sin" else np.full_like(t, -2.0)
        return np.where(active, wave, 0.0)
