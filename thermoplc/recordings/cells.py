"""The cells of a CSV recording's data lines as numbers: decimal (points or commas), a REAL's 32 bits as a PLC trace
exports them, a missing value left to the gap rule; anything else refused by line and column, with what to do."""
from __future__ import annotations

import csv
import re

import numpy as np

from thermoplc.base.binary32 import f32_from_bits
from thermoplc.base.errors import UserError
from thermoplc.recordings.timestamps import looks_dated


NUMBER = re.compile(r"\s*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\s*$|\s*[+-]?(nan|inf|infinity)\s*$",
                    re.IGNORECASE | re.ASCII)


# a REAL written as its 32 bits, as a PLC trace exports a DWORD: TIA's 16#3F80_0000, STEP 7's
# DW#16#3F800000 or C's 0x3F800000
BINARY32_BITS = re.compile(r"\s*(?:(?:DW#)?16#|0x)([0-9A-F]{4})_?([0-9A-F]{4})\s*$", re.ASCII | re.IGNORECASE)


DATE_HINT = (" (a date or a clock time: give the time column as --time COLUMN; a date column beside a clock-time "
             "column is joined to it)")
GAP_HINT = " (a missing value: give --gaps drop to drop its row, or --gaps hold:30s to hold the value before it)"
MISSING = frozenset(("", "#n/a", "n/a", "#nv", "na", "nan", "null", "none", "---", "--", "-", "#value!", "#div/0!"))


def cell_value(cell: str) -> float | None:
    """A cell's number: decimal, or the binary32 value of 8 hexadecimal digits; None if neither."""
    if NUMBER.match(cell):
        return float(cell)
    bits = BINARY32_BITS.match(cell)
    return f32_from_bits(int(bits.group(1) + bits.group(2), 16)) if bits else None


def csv_fields(path: str, line: int, text: str, delimiter: str) -> list[str]:
    """One line's fields; a quote that never closes or a field beyond the csv module's limit is named."""
    try:
        return next(csv.reader([text], delimiter=delimiter), [])
    except csv.Error as exc:
        raise UserError(f"{path}:{line}: cannot split the line into fields ({exc}); expected numbers separated by "
                        f"{delimiter!r}") from None


def parse_cells(path: str, header: list[str], text_lines: list[str], numbers: list[int], delimiter: str,
                 comma_decimal: bool, sparse: frozenset = frozenset(), gaps: bool = False
                 ) -> tuple[np.ndarray, np.ndarray | None]:
    """Rows of numbers, and where a cell was missing (`gaps`: the gap rule decides; else such a cell is refused).
    The fast C parser first, the careful one for the message when it fails. An empty cell of a `sparse` column (a
    probed target between its measurements) is NaN; anywhere else, and a NaN written out anywhere, is a gap."""
    written = text_lines
    if comma_decimal:
        _refuse_points(path, header, written, numbers, delimiter)
        text_lines = [text.replace(",", ".") for text in text_lines]
    block = None
    if all(text.isascii() for text in text_lines):  # the C parser strips Unicode spaces the careful one refuses
        try:
            with np.errstate(all="ignore"):
                block = np.loadtxt(text_lines, delimiter=delimiter, dtype=np.float64, ndmin=2, quotechar='"',
                                   comments=None)
            empty = np.zeros(block.shape, bool)
        except ValueError:
            block = None
    if block is None or block.shape[1] != len(header):
        block, empty = _parse_cells_one_by_one(path, header, written, numbers, delimiter, sparse, comma_decimal, gaps)
    bad = ~np.isfinite(block) & ~empty
    missing = np.zeros(block.shape, bool) if gaps else None
    for r, c in np.argwhere(bad):
        cell = csv_fields(path, numbers[r], written[r], delimiter)[c]
        if gaps and cell.strip().lower() in MISSING:
            missing[r, c] = header[c] not in sparse  # a probed target's missing cell: not measured there
            continue
        raise UserError(f"{path}:{numbers[r]}:{c + 1}: column {header[c]!r}: expected a finite number, "
                        f"found {cell.strip()!r}{GAP_HINT if cell.strip().lower() in MISSING else ''}")
    return block, missing


def _refuse_points(path: str, header: list[str], text_lines: list[str], numbers: list[int], delimiter: str) -> None:
    """In a file of decimal commas a '.' is a thousands separator (7.500 rpm) or a decimal point of another
    convention: either way not a number this reader may guess, so it is named where it is, as written."""
    for line, text in zip(numbers, text_lines):
        if "." in text:
            fields = csv_fields(path, line, text, delimiter)
            for column, cell in enumerate(fields if len(fields) == len(header) else ()):  # else: the count is named
                if "." in cell and looks_dated(cell):
                    raise UserError(f"{path}:{line}:{column + 1}: column {header[column]!r}: expected a number, found "
                                    f"{cell.strip()!r}{DATE_HINT}")
                if "." in cell:
                    raise UserError(f"{path}:{line}:{column + 1}: column {header[column]!r}: {cell.strip()!r} has a "
                                    f"'.' in a file read with decimal commas (';' between the columns); expected "
                                    f"a number such as 7500 or 21,5 (no thousands separator), or --decimal . if "
                                    f"the file's decimals are points")


def _parse_cells_one_by_one(path: str, header: list[str], text_lines: list[str], numbers: list[int],
                            delimiter: str, sparse: frozenset, comma_decimal: bool, gaps: bool = False
                            ) -> tuple[np.ndarray, np.ndarray]:
    """The rows the C parser refused: binary32 bit patterns are read here, an empty cell of a sparse column
    is NaN (and marked in the second array), a missing value NaN when `gaps` (the gap rule decides), anything
    else is named as written."""
    block = np.empty((len(text_lines), len(header)))
    empty = np.zeros(block.shape, bool)
    for r, (line, text) in enumerate(zip(numbers, text_lines)):
        row = csv_fields(path, line, text, delimiter)
        if len(row) != len(header):
            quote = " (a '\"' opens a quoted field that runs to the end of the line)" if '"' in text else ""
            raise UserError(f"{path}:{line}: {len(row)} fields, expected {len(header)} as in the header{quote}")
        for c, cell in enumerate(row):
            if header[c] in sparse and (not cell.strip() or gaps and cell.strip().lower() in MISSING):
                block[r, c], empty[r, c] = np.nan, True  # not measured here
                continue
            value = cell_value(cell.replace(",", ".") if comma_decimal else cell)
            if value is None and gaps and cell.strip().lower() in MISSING:
                value = np.nan
            if value is None:
                shown = cell.strip(" \t") if len(cell) <= 40 else cell.strip(" \t")[:30] + f"... ({len(cell)} characters)"
                hint = " (a REAL's 32 bits are 8 hexadecimal digits: 16#3F800000 or 0x3F800000)" \
                    if cell.strip().lower().startswith(("0x", "16#", "dw#")) else \
                    " (a runs table? give it as --runs TABLE)" if header[c] == "file" else \
                    GAP_HINT if cell.strip().lower() in MISSING else \
                    DATE_HINT if looks_dated(cell) or re.fullmatch(r"\s*\d{1,2}:\d{2}(:\d{2}([.,]\d+)?)?\s*", cell) else ""
                raise UserError(f"{path}:{line}:{c + 1}: column {header[c]!r}: expected a number, found "
                                f"{shown!r}{hint}")
            block[r, c] = value
    return block, empty
