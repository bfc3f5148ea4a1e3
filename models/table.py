"""Reading recorded data (CSV) into named float64 columns, with errors that point at the cell."""
from __future__ import annotations

import csv
import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from thermoplc.errors import UserError


@dataclass(frozen=True)
class Table:
    path: str
    columns: dict  # name -> float64 array
    sha256: str
    lines: tuple[int, ...]  # line number in the file of each row

    @property
    def rows(self) -> int:
        return len(next(iter(self.columns.values())))

    def column(self, name: str) -> np.ndarray:
        if name not in self.columns:
            raise UserError(f"{self.path}: no column {name!r}; the header has {', '.join(self.columns)}")
        return self.columns[name]


def read_table(path: str | Path, time_column: str | None = "time_s") -> Table:
    """Read a comma-separated file with one header line; every cell must be a finite number."""
    path = str(path)
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise UserError(f"{path}: cannot read: {exc.strerror}") from None
    try:
        content = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise UserError(f"{path}: not a UTF-8 text file (byte {exc.start} is {raw[exc.start]:#04x})") from None
    rows = list(csv.reader(content.splitlines()))
    if not rows:
        raise UserError(f"{path}: file is empty; expected a header line and data rows")
    header = [h.strip() for h in rows[0]]
    seen = set()
    for col, name in enumerate(header, start=1):
        if not name:
            raise UserError(f"{path}:1:{col}: empty column name in the header")
        if name in seen:
            raise UserError(f"{path}:1:{col}: column {name!r} appears twice in the header")
        seen.add(name)
    body = [(number, row) for number, row in enumerate(rows[1:], start=2) if any(cell.strip() for cell in row)]
    if not body:
        raise UserError(f"{path}: header only, no data rows")
    values = np.empty((len(body), len(header)))
    for r, (line, row) in enumerate(body):
        if len(row) != len(header):
            raise UserError(f"{path}:{line}: {len(row)} fields, expected {len(header)} as in the header")
        for c, cell in enumerate(row):
            try:
                value = float(cell)
            except ValueError:
                raise UserError(f"{path}:{line}:{c + 1}: column {header[c]!r}: expected a number, found {cell.strip()!r}") from None
            if not math.isfinite(value):
                raise UserError(f"{path}:{line}:{c + 1}: column {header[c]!r}: expected a finite number, found {cell.strip()!r}")
            values[r, c] = value
    columns = {name: values[:, i].copy() for i, name in enumerate(header)}
    if time_column is not None:
        if time_column not in columns:
            raise UserError(f"{path}: no time column {time_column!r} (set it with --time); the header has {', '.join(header)}")
        t = columns[time_column]
        bad = np.nonzero(np.diff(t) <= 0)[0]
        if len(bad):
            line = body[bad[0] + 1][0]
            raise UserError(f"{path}:{line}: column {time_column!r}: time must increase strictly, "
                            f"found {t[bad[0] + 1]!r} after {t[bad[0]]!r}")
    return Table(path, columns, hashlib.sha256(raw).hexdigest(), tuple(line for line, _ in body))


def write_table(columns: dict) -> str:
    """CSV text for named columns; values rounded to 6 decimals, far below any sensor's noise."""
    names = list(columns)
    arrays = [np.asarray(columns[n]) for n in names]
    lines = [",".join(names)]
    for i in range(len(arrays[0])):
        lines.append(",".join(_cell(a[i]) for a in arrays))
    return "\n".join(lines) + "\n"


def _cell(v) -> str:
    if isinstance(v, (np.integer, int)):
        return str(int(v))
    return f"{float(v):.6f}".rstrip("0").rstrip(".") if float(v) != 0 else "0"
