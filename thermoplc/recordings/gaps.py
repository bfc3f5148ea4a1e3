"""Missing cells of a logger export (`#N/A`, empty, `NaN`, `---`) under the rule the user chose with --gaps: refused
(the default: the reader names the first one), the rows that hold one dropped, or each held at its column's last
value for at most a stated time. What was done is counted for the console; a rule that cannot apply is refused by
line and column."""
from __future__ import annotations

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.recordings.reading import Reading


def apply_gaps(path: str, columns: dict, missing: dict, lines: np.ndarray, time_column: str | None,
               reading: Reading) -> tuple[dict, np.ndarray, str | None]:
    """The columns and line numbers after the rule; `missing`: column -> where its cells were missing (only the
    columns that have any). The note says what was done, or None when nothing was missing."""
    if not missing:
        return columns, lines, None
    if reading.gaps == "drop":
        return _drop(path, columns, missing, lines, reading)
    return _hold(path, columns, missing, lines, time_column, reading)


def _first(missing: dict, lines: np.ndarray) -> tuple[int, str]:
    """The line and column of the first missing cell (by line, then by column order)."""
    row, name = min((int(np.flatnonzero(where)[0]), name) for name, where in missing.items())
    return int(lines[row]), name


def _drop(path: str, columns: dict, missing: dict, lines: np.ndarray, reading: Reading):
    gone = np.logical_or.reduce(list(missing.values()))
    if gone.all():
        raise UserError(f"{path}: every data row has a missing cell, so --gaps drop leaves none; expected a column "
                        f"of measured values (is a column empty throughout? leave it out of the export)")
    line, name = _first(missing, lines)
    keep = ~gone
    note = (f"--gaps {reading.gaps_text}: dropped {int(gone.sum()):,} of {len(gone):,} rows with a missing cell "
            f"(the first at line {line}, column {name!r})")
    return {n: v[keep] for n, v in columns.items()}, lines[keep], note


def _hold(path: str, columns: dict, missing: dict, lines: np.ndarray, time_column: str | None, reading: Reading):
    option = f"--gaps {reading.gaps_text}"
    if time_column is None or time_column not in columns:
        raise UserError(f"{path}: {option} holds a value for a time, and no time column is read here; give --gaps drop")
    if time_column in missing:
        line = int(lines[np.flatnonzero(missing[time_column])[0]])
        raise UserError(f"{path}:{line}: column {time_column!r}: the time is missing; {option} holds measured values, "
                        f"not the time: give --gaps drop, or fill the time in the export")
    t = columns[time_column]
    held_cells, longest, filled = 0, 0.0, dict(columns)
    for name, where in missing.items():
        if where[0]:
            raise UserError(f"{path}:{int(lines[0])}: column {name!r}: missing in the first row, so {option} has no "
                            f"value to hold; give --gaps drop, or fill the cell in the export")
        last = np.maximum.accumulate(np.where(where, 0, np.arange(len(where))))  # each row's last measured row
        held_for = t - t[last]
        too_long = np.flatnonzero(where & (held_for > reading.hold_s * (1 + 1e-9)))  # 0.1 + 0.2 is no longer 0.3
        if len(too_long):
            row = int(too_long[0])
            raise UserError(f"{path}:{int(lines[row])}: column {name!r}: missing for {held_for[row]:g} s since its last "
                            f"value at line {int(lines[last[row]])}, longer than {option} holds ({reading.hold_s:g} s); "
                            f"give a longer hold, --gaps drop, or fill the cells in the export")
        filled[name] = columns[name][last]
        held_cells += int(where.sum())
        longest = max(longest, float(held_for[where].max()))
    line, name = _first(missing, lines)
    note = (f"{option}: held {held_cells:,} missing cells in {len(missing)} column(s) at their last value, for at "
            f"most {longest:g} s (the first at line {line}, column {name!r})")
    return filled, lines, note
