"""What the first data lines of a logger export say about its layout: a units row under the header, and a time
column written as date-times rather than seconds, perhaps as a date column and a clock-time column (recordings/table.py
reads the numbers; this module converts)."""
from __future__ import annotations

from typing import Callable

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.recordings.reading import Reading
from thermoplc.recordings.timestamps import (excel_seconds, looks_clock, looks_date_only, looks_dated,
                                             seconds_since_first)
from thermoplc.recordings.units import (conversion as unit_conversion, is_units_row as units_row, named_unit,
                                        time_unit_problem, unit_key)


class Layout:
    """What the first data lines say about the file: a units row (its cells) and whether the time column holds
    date-times (their cells and lines are gathered here, the parsed time column set from them at the end)."""

    def __init__(self, path: str, header: list[str], delimiter: str, time_column: str | None,
                 numeric: Callable[[str], bool], split: Callable[[int, str], list[str]], reading: Reading = Reading(),
                 missing: Callable[[str], bool] = lambda cell: False):
        self.path, self.header, self.delimiter, self.time_column = path, header, delimiter, time_column
        self.numeric, self.split = numeric, split  # whether a cell is a number; a line's fields (the reader's rules)
        self.missing = missing  # whether a cell is a missing value (the gap rule decides its row)
        self.time_format = reading.time_format
        self.units: list[str] | None = None
        self.units_line = 0
        self.dated: int | None = None  # the time column's index when it holds date-times
        self.joined: int | None = None  # the index of the other half when a date and a clock time are two columns
        self.rows = 0  # data lines seen, the units row included
        self.decided = False  # whether the time column's form is known (on the first row whose time is there)
        self.pending: list[int] = []  # the lines before it, their time missing
        self.zoned = False  # whether the date-times carry their UTC offset
        self.cells: list[str] = []
        self.lines: list[int] = []

    def row(self, line: int, text: str) -> str | None:
        """A data line as the number parser is to read it (a date-time cell set aside, 0 in its place); None for the
        units row. The first line may be the units row; the first row of numbers says whether the time is dated."""
        self.rows += 1
        if self.rows == 1 and self.units_in(line, text):
            return None
        if not self.decided:
            if self.time_missing(line, text):  # the row goes by the gap rule; the next one shows the form
                self.pending.append(line)
                return self.without_text(line, text)
            self.decided = True
            self.dated = self.dated_column(line, text)
            if self.dated is not None:
                self.cells, self.lines = [None] * len(self.pending), list(self.pending)
            elif self.time_format not in ("auto", "excel") and self.time_column in self.header:
                raise UserError(f"{self.path}:{line}: column {self.time_column!r}: --time-format {self.time_format} "
                                f"reads date-times written as text; this column holds numbers (seconds, or Excel "
                                f"serial days with --time-format excel)")
        return self.take_time(line, text) if self.dated is not None else text

    def time_missing(self, line: int, text: str) -> bool:
        """Whether the row's time cell is a missing value (under a gap rule: never without one)."""
        fields = self.split(line, text)
        return (self.time_column in self.header and len(fields) == len(self.header)
                and self.missing(fields[self.header.index(self.time_column)]))

    def without_text(self, line: int, text: str) -> str:
        """A row with no time, before the time's form is known: its text cells (a date half) as 0, for the gap rule
        drops or refuses the row by its missing time."""
        fields = self.split(line, text)
        return self.delimiter.join(cell if self.numeric(cell) or self.missing(cell) else "0" for cell in fields) + "\n"

    def units_in(self, line: int, text: str) -> bool:
        """Whether the first data line is a units row (kept)."""
        fields = self.split(line, text)
        if len(fields) == len(self.header) and units_row(fields, self.numeric):
            self.units, self.units_line = fields, line
        return self.units is not None

    def dated_column(self, line: int, text: str) -> int | None:
        """The time column's index when the first row's time is a date-time (or --time-format names a pattern), not a
        number; a date and a clock time in two columns are found here as a pair (the other half kept in `joined`)."""
        if self.time_column not in self.header:
            return None
        fields = self.split(line, text)
        k = self.header.index(self.time_column)
        cell = fields[k] if len(fields) == len(self.header) else ""
        if self.numeric(cell) or not fields or len(fields) != len(self.header):
            return None
        half = looks_date_only(cell) or looks_clock(cell)
        if half:
            partner = looks_clock if looks_date_only(cell) else looks_date_only
            others = [j for j, other in enumerate(fields) if j != k and partner(other)]
            if len(others) == 1:
                self.joined = others[0]
                return k
            if looks_clock(cell):
                found = "several" if others else "none found"
                raise UserError(f"{self.path}:{line}: column {self.time_column!r}: {cell.strip()!r} is a clock time "
                                f"without a date; expected a date-time, or one date column beside it ({found}): a "
                                f"time of day alone cannot tell one day from the next")
        return k if "%" in self.time_format or looks_dated(cell) else None

    def take_time(self, line: int, text: str) -> str:
        """The line with its date-time cell (and the date or clock half beside it) kept aside and a 0 in its place; a
        missing time stays for the gap rule (the time is set at the end)."""
        fields = self.split(line, text)
        if len(fields) != len(self.header):
            return text  # the field count is refused with the rest
        halves = [fields[self.dated]] if self.joined is None else \
            [fields[min(self.dated, self.joined)], fields[max(self.dated, self.joined)]]
        if self.joined is not None and looks_clock(halves[0]) and not looks_clock(halves[1]):
            halves.reverse()  # the date first, as the forms are written
        gone = any(self.missing(half) for half in halves)
        self.cells.append(None if gone else " ".join(half.strip() for half in halves))
        self.lines.append(line)
        fields[self.dated] = next((half for half in halves if self.missing(half)), "0")  # a missing time: its cell
        if self.joined is not None:
            fields[self.joined] = "0"
        return self.delimiter.join(fields) + "\n"

    def convert(self, columns: dict, lines: np.ndarray) -> tuple[str, ...]:
        """Date-times (or Excel serial days) to seconds since the first row, each column to thermoplc's unit; what
        was done, said. A missing time (None among the cells) reads as NaN for the gap rule."""
        notes, header = [], self.header
        if self.dated is not None:
            name = header[self.dated]
            present = [k for k, cell in enumerate(self.cells) if cell is not None]
            seconds, first = seconds_since_first([self.cells[k] for k in present], [self.lines[k] for k in present],
                                                 self.path, name, self.time_format)
            self.zoned = first is not None and first.tzinfo is not None
            times = np.full(len(self.cells), np.nan)
            times[present] = seconds
            columns[name] = times
            if self.joined is not None:
                del columns[header[self.joined]]
                name = f"{header[min(self.dated, self.joined)]} + {header[max(self.dated, self.joined)]}"
            if first is not None:
                notes.append(f"{name}: date-times read as seconds since {first.isoformat(sep=' ')} (the first row)")
        elif self.time_format == "excel" and self.time_column in columns:
            seconds, first = excel_seconds(columns[self.time_column], lines, self.path, self.time_column)
            columns[self.time_column] = seconds
            notes.append(f"{self.time_column}: Excel serial days read as seconds since {first.isoformat(sep=' ')} (the "
                         f"first row), to the millisecond")
        converted = []
        for k, name in enumerate(header):
            if self.units is None or k in (self.dated, self.joined) or (self.time_format == "excel" and
                                                                         name == self.time_column):
                continue
            time = name == self.time_column
            problem = time_unit_problem(self.units[k]) if time else None
            if problem:
                raise UserError(f"{self.path}:{self.units_line}:{k + 1}: the units row says {self.units[k].strip()!r} for "
                                f"the time column {name!r}: {problem}")
            scale = unit_conversion(self.units[k], time)
            if scale is None:
                continue
            if named_unit(name) == unit_key(self.units[k]):
                raise UserError(f"{self.path}:{self.units_line}:{k + 1}: column {name!r} is converted from "
                                f"{self.units[k].strip()} by the units row, but its name says {self.units[k].strip()}: "
                                f"the block's input or output named after it would too; rename the column without its "
                                f"unit (thermoplc computes in s, degC, um and rpm)")
            columns[name] = columns[name] * scale[0] + scale[1]
            converted.append(f"{name} (from {self.units[k].strip()})")
        if self.units is not None:
            notes.append("units row read" + (f"; converted to s, degC, um, rpm: {', '.join(converted)}"
                                             if converted else ""))
        return tuple(notes)
