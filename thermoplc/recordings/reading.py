"""How a recording's text is read: the options every command that reads recordings takes (--decimal, --gaps,
--time-format), kept in one record so that fit, verify, diff and the campaign readers read a file alike, and the
model file can say how its data were read (verify reads them so again)."""
from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import datetime

from thermoplc.base.errors import UserError
from thermoplc.base.values import DURATION_UNITS

GAP_CHOICES = "refuse, drop or hold:DURATION (hold:30s, hold:2min)"
TIME_FORMATS = ("auto", "day-first", "month-first", "excel")
TIME_FORMAT_CHOICES = ("auto (ISO 8601, or dates whose order the file shows), day-first, month-first, excel "
                       "(Excel serial days) or a strptime pattern such as '%d/%m/%Y %H:%M:%S'")
_HOLD = re.compile(r"\s*hold:\s*(\d+(?:\.\d*)?|\.\d+)\s*(ms|s|min|h)?\s*\Z", re.IGNORECASE)


@dataclass(frozen=True)
class Reading:
    """decimal: auto, '.' or ','; gaps: refuse, drop (the rows with a missing cell) or hold (a missing cell takes
    its column's last value, for at most hold_s seconds); time_format: one of TIME_FORMATS or a strptime pattern."""
    decimal: str = "auto"
    gaps: str = "refuse"
    hold_s: float = 0.0
    time_format: str = "auto"

    def __post_init__(self) -> None:
        """A Reading built in Python (thermoplc.api) is checked as the options are."""
        hold = self.gaps == "hold" and not (isinstance(self.hold_s, (int, float)) and 1e-3 <= self.hold_s <= 366 * 86400)
        if self.gaps not in ("refuse", "drop", "hold") or hold:
            raise UserError(f"Reading: gaps {self.gaps!r}, hold_s {self.hold_s!r}; expected refuse, drop, or hold with "
                            f"hold_s from 0.001 to {366 * 86400} seconds")
        problem = (None if self.decimal in ("auto", ".", ",") else f"--decimal: expected auto, . or ',', found "
                   f"{self.decimal!r}") or (time_format_problem(self.time_format) and
                                           f"--time-format: {time_format_problem(self.time_format)}")
        if problem:
            raise UserError(f"Reading: {problem}")

    @property
    def gaps_text(self) -> str:
        """The rule as --gaps takes it, the time held to the last digit (a model file's verify holds as long)."""
        if self.gaps != "hold":
            return self.gaps
        seconds = repr(self.hold_s)  # from 1 ms to 366 days: plain digits, never an exponent
        return f"hold:{seconds[:-2] if seconds.endswith('.0') else seconds}s"

    def written(self) -> dict:
        return {"decimal": self.decimal, "gaps": self.gaps_text, "time_format": self.time_format}

    def to_doc(self) -> dict:
        """What the model file records: the options that are not the default (an empty dict: read as by default)."""
        default = Reading().written()
        return {k: v for k, v in self.written().items() if v != default[k]}

    @staticmethod
    def from_doc(doc: dict) -> Reading:
        """The Reading a model file's 'reading' field records (absent options: the defaults)."""
        return resolved(doc)


def gaps_problem(text: str) -> tuple[tuple[str, float] | None, str | None]:
    """--gaps as (policy, seconds held), or why it is none."""
    if not isinstance(text, str):
        return None, f"expected {GAP_CHOICES}, found {text!r}"
    if text.strip().lower() in ("refuse", "drop"):
        return (text.strip().lower(), 0.0), None
    held = _HOLD.match(text)
    if not held:
        return None, f"expected {GAP_CHOICES}, found {text!r}"
    seconds = float(held.group(1)) * DURATION_UNITS[(held.group(2) or "s").lower()]
    if not 1e-3 <= seconds <= 366 * 86400:
        return None, f"expected a time held from 1ms to 366 days, found {text!r}"
    return ("hold", seconds), None


def time_format_problem(text: str) -> str | None:
    """Why --time-format is none of the named forms nor a strptime pattern that reads back what it writes, or None."""
    if not isinstance(text, str) or not text.strip():
        return f"expected {TIME_FORMAT_CHOICES}, found {text!r}"
    if text in TIME_FORMATS:
        return None
    if "%" not in text:
        return f"expected {TIME_FORMAT_CHOICES}, found {text!r}"
    try:
        datetime.strptime(datetime(2024, 3, 1, 20, 15, 30).strftime(text), text)
    except ValueError as exc:
        return f"{text!r} is no strptime pattern ({exc}); expected one such as '%d/%m/%Y %H:%M:%S'"
    return None


def reading_problem(decimal, gaps, time_format) -> tuple[Reading | None, str | None]:
    """The options as one Reading, or the first one's problem (named as its option)."""
    if decimal not in ("auto", ".", ","):
        return None, f"--decimal: expected auto, . or ',', found {decimal!r}"
    found, problem = gaps_problem(gaps)
    if problem:
        return None, f"--gaps: {problem}"
    problem = time_format_problem(time_format)
    if problem:
        return None, f"--time-format: {problem}"
    return Reading(decimal, found[0], found[1], time_format), None


def resolved(given: dict, recorded: Reading = Reading()) -> Reading:
    """The options `given` (decimal, gaps, time_format as written; None: not given) over the `recorded` ones (a
    model file's: verify reads the data as fit did unless told otherwise)."""
    written = recorded.written()
    found, problem = reading_problem(*(given.get(k) if given.get(k) is not None else written[k] for k in written))
    if problem:
        raise UserError(problem)
    return found
