"""What the first data lines of a logger export say about its layout: a units row under the header, and a time
column written as date-times rather than seconds (recordings/table.py reads the numbers; this module converts)."""
from __future__ import annotations

from typing import Callable

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.recordings.timestamps import looks_dated, seconds_since_first
from thermoplc.recordings.units import (conversion as unit_conversion, is_units_row as units_row, named_unit,
                                        time_unit_problem, unit_key)


class Layout:
    """What the first data lines say about the file: a units row (its cells) and whether the time column holds
    date-times (their cells and lines are gathered here, the parsed time column set from them at the end)."""

    def __init__(self, path: str, header: list[str], delimiter: str, time_column: str | None,
                 numeric: Callable[[str], bool], split: Callable[[int, str], list[str]]):
        self.path, self.header, self.delimiter, self.time_column = path, header, delimiter, time_column
        self.numeric, self.split = numeric, split  # whether a cell is a number; a line's fields (the reader's rules)
        self.units: list[str] | None = None
        self.units_line = 0
        self.dated: int | None = None  # the time column's index when it holds date-times
        self.rows = 0  # data lines seen, the units row included
        self.zoned = False  # whether the date-times carry their UTC offset
        self.cells: list[str] = []
        self.lines: list[int] = []

    def row(self, line: int, text: str) -> str | None:
        """A data line as the number parser is to read it (a date-time cell set aside, 0 in its place); None for the
        units row. The first line may be the units row; the first row of numbers says whether the time is dated."""
        self.rows += 1
        if self.rows == 1 and self.units_in(line, text):
            return None
        if self.rows == (2 if self.units is not None else 1):
            self.dated = self.dated_column(line, text)
        return self.take_time(line, text) if self.dated is not None else text

    def units_in(self, line: int, text: str) -> bool:
        """Whether the first data line is a units row (kept)."""
        fields = self.split(line, text)
        if len(fields) == len(self.header) and units_row(fields, self.numeric):
            self.units, self.units_line = fields, line
        return self.units is not None

    def dated_column(self, line: int, text: str) -> int | None:
        """The time column's index when the first row's time is a date-time, not a number."""
        if self.time_column not in self.header:
            return None
        fields = self.split(line, text)
        k = self.header.index(self.time_column)
        cell = fields[k] if len(fields) == len(self.header) else ""
        return k if not self.numeric(cell) and looks_dated(cell) else None

    def take_time(self, line: int, text: str) -> str:
        """The line with its date-time cell kept aside and a 0 in its place (the time is set at the end)."""
        fields = self.split(line, text)
        if len(fields) != len(self.header):
            return text  # the field count is refused with the rest
        self.cells.append(fields[self.dated])
        self.lines.append(line)
        fields[self.dated] = "0"
        return self.delimiter.join(fields) + "\n"

    def convert(self, columns: dict) -> tuple[str, ...]:
        """Date-times to seconds since the first row, each column to thermoplc's unit; what was done, said."""
        notes, header = [], self.header
        if self.dated is not None:
            name = header[self.dated]
            seconds, first = seconds_since_first(self.cells, self.lines, self.path, name)
            self.zoned = first.tzinfo is not None
            columns[name] = np.asarray(seconds, np.float64)
            notes.append(f"{name}: date-times read as seconds since {first.isoformat(sep=' ')} (the first row)")
        converted = []
        for k, name in enumerate(header):
            if self.units is None or k == self.dated:
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
