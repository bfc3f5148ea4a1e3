"""The checks of a value that the command line and the Python API share, in the command line's words: a number
in its range, a column name, a list of column names, a block cycle. The command line parses text and asks
these; the API's request records ask them of what a caller passed, so both refuse the same values alike."""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from thermoplc.base.errors import UserError

UNIX_SECONDS = 1e12  # a time limit in seconds: wide enough for a logger's Unix time stamps (2026: 1.8e9 s)


def number_problem(value: Any, kind: type, low: float, high: float, what: str = "", shown: str | None = None
                   ) -> str | None:
    """Why `value` is no finite `kind` (int or float) within [low, high], or None; `shown` is how the value was
    written (the command line's text), else its repr."""
    types = (int, np.integer) if kind is int else (int, float, np.integer, np.floating)
    if not isinstance(value, types) or isinstance(value, (bool, np.bool_)):
        return f"expected {'an integer' if kind is int else 'a number'}, found {value!r}"
    if not (math.isfinite(value) and low <= value <= high):
        bound = (lambda v: f"{int(v):,}") if kind is int else (lambda v: f"{v:g}")
        return (f"expected {what or 'a value'} from {bound(low)} to {bound(high)}, "
                f"found {shown if shown is not None else repr(value)}")
    return None


def cycle_problem(value: Any, shown: str | None = None) -> str | None:
    """Why `value` is no block cycle in seconds (more than 0, at most a day, a whole number of ms), or None."""
    problem = number_problem(value, float, 0.001, 86400.0, "the block's cycle in seconds", shown)
    if problem is None and abs(value * 1000 - round(value * 1000)) > 1e-6:
        return (f"expected a whole number of milliseconds (a PLC cycle is set in ms), "
                f"found {shown if shown is not None else repr(value)}")
    return problem


def name_problem(value: Any, optional: bool = False) -> str | None:
    """Why `value` is no column name (a non-empty str; None where `optional`), or None."""
    if value is None and optional:
        return None
    if not isinstance(value, str) or not value:
        return f"expected a column name, found {value!r}"
    return None


def names_problem(value: Any) -> str | None:
    """Why `value` is no sequence of column names (a tuple or list of non-empty str), or None. A lone string is
    refused: taken as a sequence it would be its letters."""
    if isinstance(value, str):
        return f"expected a tuple of column names, found the string {value!r} (give ({value!r},))"
    if not isinstance(value, (tuple, list)):
        return f"expected a tuple of column names, found {value!r}"
    bad = [v for v in value if name_problem(v)]
    return f"expected a tuple of column names, found {bad[0]!r} in it" if bad else None


@dataclass(frozen=True)
class Every:
    """A probing schedule as the user wrote it: N calls (a bare number) or a duration (30min, 1800s, 0.5h)."""
    text: str
    calls: int | None = None
    seconds: float | None = None

    def __str__(self) -> str:
        return self.text

    def calls_at(self, period_s: float) -> int:
        """The schedule in calls of a block running every `period_s`; a duration that is no whole number of calls
        (within 1 %) is refused with the two nearest."""
        if self.calls is not None:
            return self.calls
        exact = self.seconds / period_s
        calls = max(int(round(exact)), 1)
        if abs(exact - calls) > 0.01 * calls:
            nearest = [f"{n * period_s:g}s" for n in (math.floor(exact), math.ceil(exact)) if n >= 1]
            raise UserError(f"--probe-every {self.text}: {exact:g} calls of {period_s:g} s, not a whole number; give "
                            f"{' or '.join(nearest)} (or a number of calls)")
        return calls


DURATION_UNITS = {"ms": 1e-3, "s": 1.0, "min": 60.0, "h": 3600.0}
_DURATION = re.compile(r"\s*(\d+(?:\.\d*)?|\.\d+)\s*(ms|s|min|h)\s*\Z", re.IGNORECASE)


def every_problem(text: str) -> tuple[Every | None, str | None]:
    """`text` as a probing schedule (N calls, or a duration such as 30min, 1800s, 0.5h), or why it is none."""
    text = text.strip()
    if text.isascii() and text.isdigit():
        calls = int(text)
        return (Every(text, calls=calls), None) if 1 <= calls <= 10 ** 9 else \
            (None, f"expected a number of calls from 1 to 1,000,000,000 or a duration (30min), found {text!r}")
    found = _DURATION.match(text)
    if not found:
        return None, (f"expected a number of calls (120) or a duration with its unit (30min, 1800s, 0.5h), "
                      f"found {text!r}")
    seconds = float(found.group(1)) * DURATION_UNITS[found.group(2).lower()]
    if not 1e-3 <= seconds <= 366 * 86400:
        return None, f"expected a duration from 1ms to 366 days, found {text!r}"
    return Every(text, seconds=seconds), None
