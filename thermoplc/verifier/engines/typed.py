"""Values by declared ST type: data cells converted for a block's inputs and for the outputs a PLC
recorded, and outputs compared as their type says (REAL by bits, integers by value, BOOL as BOOL).

A cell the type cannot hold is an error naming the file, column and line: read as a BOOL, an INT
input of 2 would silently become TRUE, and a REAL above FLT_MAX would become Inf.
"""
from __future__ import annotations

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.recordings.table import Table
from thermoplc.base.binary32 import INT_RANGES


def cells_as(table: Table, column: str, base: str, what: str) -> np.ndarray:
    """Column `column` of `table` as values of ST type `base` (REAL float32, BOOL bool, integers int64)."""
    if base == "REAL":
        return table.real_column(column, what)
    values = table.column(column)

    def refuse(bad: np.ndarray, expected: str) -> None:
        table.refuse_cell(column, bad, f"{what} of type {base}", expected)
    if base == "BOOL":
        not_bool = ~np.isin(values, (0.0, 1.0))
        if not_bool.any():
            refuse(not_bool, "0 or 1")
        return values == 1.0
    if base in INT_RANGES:
        lo, hi = INT_RANGES[base]
        bad = ~np.isfinite(values) | (values != np.round(values)) | (values < lo) | (values > hi)
        if bad.any():
            refuse(bad, f"a whole number in {lo}..{hi}")
        return values.astype(np.int64)
    raise UserError(f"{table.path}: column {column!r}: {what} has type {base}, which verify cannot compare")


def differing_rows(base: str, got, want) -> np.ndarray:
    """Rows where a block output differs from what was expected, by the output's declared type."""
    if base == "REAL":
        return np.flatnonzero(np.asarray(got, np.float32).view(np.uint32) != np.asarray(want, np.float32).view(np.uint32))
    if base == "BOOL":
        return np.flatnonzero(np.asarray(got, bool) != np.asarray(want, bool))
    return np.flatnonzero(np.asarray(got, np.int64) != np.asarray(want, np.int64))


def first_non_finite(values) -> int | None:
    """The first row where a REAL output is NaN or Inf: such a value must never reach the NC."""
    bad = np.flatnonzero(~np.isfinite(np.asarray(values, np.float32)))
    return int(bad[0]) if len(bad) else None
