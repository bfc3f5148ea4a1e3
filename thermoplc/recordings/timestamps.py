"""Date-time cells of a logger export turned into seconds since the first row.

Loggers, PLC traces and spreadsheets write the time as a date and a clock time, not as seconds. Read
here: ISO 8601 (`2024-03-01 08:00:00`, `2024-03-01T08:00:00.250`, with or without a zone: `Z`,
`+01:00`), day-first dotted dates (`01.03.2024 08:00:00`: the only order dotted dates are written in)
and slashed dates (`03/01/2024 8:00:00 AM`) when the file itself says which order it is (a day above
12 in either place): when every row reads both ways the file is refused, never guessed. Times with a
zone are compared in UTC, so a daylight-saving change is no jump; times without one that go back are
refused by the reader's strictly-increasing check, named as a clock change. `--time-format` settles what the file
cannot: day-first or month-first slashed dates, a strptime pattern, or Excel serial days (a number of days since
1899-12-30, rounded to the millisecond). A date and a clock time in two columns are joined with a space first.
"""
from __future__ import annotations

import re
from datetime import datetime, timedelta, timezone
from typing import Sequence

import numpy as np

from thermoplc.base.errors import UserError

_ISO = re.compile(r"\d{4}-\d{2}-\d{2}(?:[T ]\d{1,2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?)?(?:Z|[+-]\d{2}:?\d{2})?\Z")
_DOTTED = re.compile(r"(\d{1,2})\.(\d{1,2})\.(\d{4})(?:[ T](\d{1,2}):(\d{2})(?::(\d{2})(?:[.,](\d+))?)?)?\Z")
_SLASHED = re.compile(r"(\d{1,2})/(\d{1,2})/(\d{4})(?:[ T](\d{1,2}):(\d{2})(?::(\d{2})(?:[.,](\d+))?)?"
                      r"(?:\s*([AaPp][Mm]))?)?\Z")
_CLOCK = re.compile(r"\d{1,2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?(?:\s*[AaPp][Mm]|Z|[+-]\d{2}:?\d{2})?\Z")
ISO_EXAMPLE = "2024-03-01 08:00:00"
EXCEL_EPOCH = datetime(1899, 12, 30)  # Excel's day 0 (its serial days count the fictitious 29 February 1900)
EXCEL_LAST_DAY = 2958465  # 9999-12-31


def looks_dated(cell: str) -> bool:
    """Whether a time cell is a date-time this module reads (the reader then converts the whole column)."""
    text = cell.strip()
    return bool(_ISO.match(text) or _DOTTED.match(text) or _SLASHED.match(text))


def looks_clock(cell: str) -> bool:
    """A clock time without a date (08:00:00, 8:00 AM): half of a date and a time written in two columns."""
    return bool(_CLOCK.match(cell.strip()))


def looks_date_only(cell: str) -> bool:
    """A date without a clock time (2024-03-01, 01.03.2024, 3/1/2024): the other half."""
    return looks_dated(cell) and ":" not in cell


def seconds_since_first(cells: Sequence[str], lines: Sequence[int], path: str, column: str,
                        time_format: str = "auto") -> tuple[list[float], datetime]:
    """Each cell's seconds after the first cell's moment, and that moment; a cell that is not a date-time of the
    first cell's form (or of `time_format`), or a zone given in some rows only, is refused by line."""
    if not cells:
        return [], None
    form = _form(cells, lines, path, column, time_format)
    moments = [form(cell.strip(), line) for cell, line in zip(cells, lines)]
    first = moments[0]
    if any((m.tzinfo is None) != (first.tzinfo is None) for m in moments):
        line = next(line for m, line in zip(moments, lines) if (m.tzinfo is None) != (first.tzinfo is None))
        raise UserError(f"{path}:{line}: column {column!r}: a time with a UTC offset and one without in the same "
                        f"column; expected every time with its offset, or none")
    return [(m - first) / timedelta(seconds=1) for m in moments], first


def excel_seconds(days: np.ndarray, lines: Sequence[int], path: str, column: str) -> tuple[np.ndarray, datetime]:
    """Excel serial days as seconds since the first row, rounded to the millisecond (a serial day's 15 digits hold
    about 10 microseconds; Excel shows at most milliseconds), and the first row's moment."""
    outside = np.flatnonzero(~np.isnan(days) & ~((days >= 1) & (days <= EXCEL_LAST_DAY)))  # NaN: the gap rule's
    if len(outside):
        row = int(outside[0])
        raise UserError(f"{path}:{lines[row]}: column {column!r}: --time-format excel reads Excel serial days "
                        f"(45352.5 is 2024-03-01 12:00), found {days[row]:.17g}; expected a day from 1 (1900-01-01) "
                        f"to {EXCEL_LAST_DAY} (9999-12-31), or give the time without --time-format excel")
    start = float(days[np.flatnonzero(~np.isnan(days))[0]]) if not np.isnan(days).all() else 1.0
    milliseconds = np.round((days - start) * 86_400_000.0)
    first = EXCEL_EPOCH + timedelta(milliseconds=round(start * 86_400_000.0))
    return milliseconds / 1000.0, first


def _form(cells: Sequence[str], lines: Sequence[int], path: str, column: str, time_format: str):
    """The parser of the column's form: `time_format`'s, else chosen on the first cell (slashed dates' order from
    the whole column)."""
    head = cells[0].strip()
    if "%" in time_format:
        return lambda text, line: _pattern(time_format, text, line, path, column)
    if time_format == "excel":
        raise _refuse(path, lines[0], column, head, "Excel serial days (a number such as 45352.5) as --time-format "
                                                    "excel says; give the date-times without it")
    if _ISO.match(head):
        return lambda text, line: _iso(text, line, path, column)
    pattern = _DOTTED if _DOTTED.match(head) else _SLASHED
    if pattern is _DOTTED and time_format == "month-first":
        raise _refuse(path, lines[0], column, head, "a slashed date for --time-format month-first (dotted dates are "
                                                    "written day first); give the times without it")
    if time_format in ("day-first", "month-first"):
        day_first = time_format == "day-first"
    else:
        day_first = True if pattern is _DOTTED else _slashed_order(cells, lines, path, column)
    return lambda text, line: _numeric(pattern, text, line, path, column, day_first=day_first)


def _pattern(pattern: str, text: str, line: int, path: str, column: str) -> datetime:
    try:
        moment = datetime.strptime(text, pattern)
        return moment.astimezone(timezone.utc) if moment.tzinfo is not None else moment
    except (ValueError, OverflowError):
        raise _refuse(path, line, column, text, f"a date-time of --time-format {pattern!r}") from None


def _refuse(path: str, line: int, column: str, text: str, expected: str) -> UserError:
    return UserError(f"{path}:{line}: column {column!r}: expected {expected}, found {text!r}")


def _iso(text: str, line: int, path: str, column: str) -> datetime:
    if not _ISO.match(text):
        raise _refuse(path, line, column, text, f"a date-time written as the first row's ({ISO_EXAMPLE})")
    written = re.sub(r"([T ])(\d):", r"\g<1>0\2:", text.replace(",", "."))  # 8:00 is 08:00 (Excel writes it so)
    try:
        moment = datetime.fromisoformat(written)
        return moment.astimezone(timezone.utc) if moment.tzinfo is not None else moment
    except (ValueError, OverflowError):
        raise _refuse(path, line, column, text, f"a date-time that exists ({ISO_EXAMPLE})") from None


def _numeric(pattern: re.Pattern, text: str, line: int, path: str, column: str, day_first: bool) -> datetime:
    found = pattern.match(text)
    order = "day first" if day_first else "month first"
    if not found:
        raise _refuse(path, line, column, text, f"a date-time written as the first row's ({order})")
    a, b, year, hour, minute, second, fraction, *half = found.groups() + (None,) * (8 - len(found.groups()))
    day, month = (a, b) if day_first else (b, a)
    hour = int(hour or 0)
    if half and half[0]:
        if not 1 <= hour <= 12:
            raise _refuse(path, line, column, text, "an hour from 1 to 12 before AM or PM")
        hour = hour % 12 + (12 if half[0].upper() == "PM" else 0)
    try:
        moment = datetime(int(year), int(month), int(day), hour, int(minute or 0), int(second or 0))
        return moment + timedelta(seconds=float(f"0.{fraction}")) if fraction else moment
    except (ValueError, OverflowError):
        raise _refuse(path, line, column, text, f"a date-time that exists ({order})") from None


def _slashed_order(cells: Sequence[str], lines: Sequence[int], path: str, column: str) -> bool:
    """Day first when some row's first number is above 12, month first when some row's second is; refused when
    the column says both or neither (03/01/2024 is 3 January in London and 1 March in Chicago)."""
    firsts, seconds = [], []
    for cell, line in zip(cells, lines):
        found = _SLASHED.match(cell.strip())
        if not found:
            raise _refuse(path, line, column, cell.strip(),
                          "a date-time written as the first row's (D/M/YYYY or M/D/YYYY)")
        firsts.append((int(found.group(1)), line))
        seconds.append((int(found.group(2)), line))
    day_first = next((line for value, line in firsts if value > 12), None)
    month_first = next((line for value, line in seconds if value > 12), None)
    if day_first is not None and month_first is not None:
        raise UserError(f"{path}:{max(day_first, month_first)}: column {column!r}: the dates are day first at line "
                        f"{day_first} and month first at line {month_first}; expected one order in the whole column")
    if day_first is None and month_first is None:
        raise UserError(f"{path}:{lines[0]}: column {column!r}: {cells[0].strip()!r} reads as day first and as "
                        f"month first in every row (no day above 12); this is not guessed: give --time-format "
                        f"day-first or --time-format month-first")
    return day_first is not None
