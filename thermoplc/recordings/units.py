"""A units row under the header (`s;°C;°C;µm`, as loggers and TIA traces export it), and the conversion of
each column to the units thermoplc computes in: seconds, degrees Celsius, micrometres, revolutions per minute.
A unit not listed here (`%`, `V`, `-`, empty) leaves its column as written."""
from __future__ import annotations

import re
from typing import Sequence

# written unit (lower case, spaces removed) -> (scale, offset): value in thermoplc's unit = scale * written + offset.
# The time column takes time units only; the other columns temperature, length and speed units (a one-letter unit
# that could mean something else, F for a force or h for a height, is not guessed at).
TIME_UNITS = {
    **dict.fromkeys(("s", "sec", "second", "seconds"), (1.0, 0.0)),
    **dict.fromkeys(("ms",), (1e-3, 0.0)),
    **dict.fromkeys(("min", "minutes"), (60.0, 0.0)),
    **dict.fromkeys(("h", "hour", "hours"), (3600.0, 0.0)),
    **dict.fromkeys(("d", "day", "days"), (86400.0, 0.0)),
}
SIGNAL_UNITS = {
    **dict.fromkeys(("°c", "degc", "c", "deg.c", "℃", "celsius"), (1.0, 0.0)),
    **dict.fromkeys(("k", "°k", "kelvin"), (1.0, -273.15)),
    **dict.fromkeys(("°f", "degf", "℉"), (5 / 9, -32 * 5 / 9)),
    **dict.fromkeys(("µm", "μm", "um", "micron", "microns"), (1.0, 0.0)),
    **dict.fromkeys(("mm",), (1000.0, 0.0)),
    **dict.fromkeys(("nm",), (1e-3, 0.0)),
    **dict.fromkeys(("m",), (1e6, 0.0)),
    **dict.fromkeys(("rpm", "1/min", "min-1", "min^-1", "u/min", "r/min"), (1.0, 0.0)),
    **dict.fromkeys(("1/s", "hz", "rps"), (60.0, 0.0)),
}
CONVERSIONS = {**TIME_UNITS, **SIGNAL_UNITS}
_BRACKETS = re.compile(r"^[\[(](.*)[\])]$")


def unit_key(cell: str) -> str:
    """A units cell as looked up: brackets, spaces and case dropped."""
    text = cell.strip()
    bracketed = _BRACKETS.match(text)
    return re.sub(r"\s+", "", bracketed.group(1) if bracketed else text).lower()


def is_units_row(cells: Sequence[str], numeric) -> bool:
    """A line of units: no cell is a number, and at least one names a unit listed here."""
    return (not any(numeric(cell) for cell in cells if cell.strip())
            and any(unit_key(cell) in CONVERSIONS for cell in cells))


def conversion(cell: str, time: bool) -> tuple[float, float] | None:
    """(scale, offset) to thermoplc's unit of the time column (`time`) or of another column, or None when the column
    stays as written (a time unit on another column, an unknown unit: left as written)."""
    found = (TIME_UNITS if time else SIGNAL_UNITS).get(unit_key(cell))
    return None if found in (None, (1.0, 0.0)) else found


def time_unit_problem(cell: str) -> str | None:
    """Why a units cell cannot be the time column's (a temperature, a length: not a time), or None."""
    key = unit_key(cell)
    if not key or key in TIME_UNITS:
        return None
    return f"its unit {cell.strip()!r} is not a time; expected s, ms, min, h or d"


def named_unit(name: str) -> str | None:
    """The unit a column's name carries at its end (`ch3 [mm]`, `t8(K)`, `E_z_mm`), as a units key, or None."""
    found = re.search(r"[\[(]([^\])]+)[\])]\s*$", name) or re.search(r"_([A-Za-z°µμ/]+)$", name)
    return unit_key(found.group(1)) if found else None
