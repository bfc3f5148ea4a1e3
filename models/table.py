"""Reading recorded data (CSV) into named float64 columns, with errors that point at the cell."""
from __future__ import annotations

import csv
import hashlib
import io
import os
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from thermoplc.binary32 import FLT_MAX
from thermoplc.errors import UserError


CHUNK_ROWS = 65536  # rows parsed at once: bounds the memory of the text being parsed
PROGRESS_ROWS = 1_000_000


@dataclass(frozen=True)
class Table:
    path: str
    columns: dict  # name -> float64 array
    sha256: str
    lines: np.ndarray  # line number in the file of each row (for .npz: the row number)

    @property
    def rows(self) -> int:
        return len(next(iter(self.columns.values())))

    def column(self, name: str) -> np.ndarray:
        if name not in self.columns:
            raise UserError(f"{self.path}: no column {name!r}; the header has {', '.join(self.columns)}")
        return self.columns[name]

    def refuse_cell(self, column: str, bad: np.ndarray, what: str, expected: str) -> None:
        """The error for the first row where `bad` holds: file, line, column, the value, what it was for."""
        row = int(np.flatnonzero(bad)[0])
        raise UserError(f"{self.path}: line {int(self.lines[row])}, column {column!r}: "
                        f"{float(self.columns[column][row]):.17g} cannot be {what}; expected {expected}")

    def real_column(self, name: str, what: str) -> np.ndarray:
        """Column `name` as binary32 values; a finite cell beyond FLT_MAX (it would become Inf) is an error."""
        values = self.column(name)
        with np.errstate(over="ignore"):
            too_big = np.isfinite(values) & np.isinf(values.astype(np.float32))  # rounds beyond the largest REAL
        if too_big.any():
            self.refuse_cell(name, too_big, f"{what} of type REAL", f"a REAL within +-{FLT_MAX:.9g}")
        return values.astype(np.float32)


class _Hashing(io.RawIOBase):
    """A binary file that feeds every byte read into a digest: the CSV is hashed in the same pass
    that parses it, not read twice."""

    def __init__(self, raw, digest):
        self.raw, self.digest = raw, digest

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        n = self.raw.readinto(buffer)
        self.digest.update(memoryview(buffer)[:n])
        return n

    def close(self) -> None:
        self.raw.close()
        super().close()


def _sha256(path: str) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


NUMBER = re.compile(r"\s*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\s*$|\s*[+-]?(nan|inf|infinity)\s*$",
                    re.IGNORECASE | re.ASCII)


def _fields(path: str, line: int, text: str, delimiter: str) -> list[str]:
    """One line's fields; a quote that never closes or a field beyond the csv module's limit is named."""
    try:
        return next(csv.reader([text], delimiter=delimiter), [])
    except csv.Error as exc:
        raise UserError(f"{path}:{line}: cannot split the line into fields ({exc}); expected numbers separated by "
                        f"{delimiter!r}") from None


def _parse_cells(path: str, header: list[str], text_lines: list[str], numbers: list[int], delimiter: str,
                 comma_decimal: bool) -> np.ndarray:
    """Rows of numbers; the fast C parser first, the careful one for the message when it fails."""
    if comma_decimal:
        text_lines = [text.replace(",", ".") for text in text_lines]
    try:
        with np.errstate(all="ignore"):
            block = np.loadtxt(text_lines, delimiter=delimiter, dtype=np.float64, ndmin=2, quotechar='"', comments=None)
    except ValueError:
        block = None
    if block is None or block.shape[1] != len(header):
        for line, text in zip(numbers, text_lines):
            row = _fields(path, line, text, delimiter)
            if len(row) != len(header):
                quote = " (a '\"' opens a quoted field that runs to the end of the line)" if '"' in text else ""
                raise UserError(f"{path}:{line}: {len(row)} fields, expected {len(header)} as in the header{quote}")
            for c, cell in enumerate(row):
                if not NUMBER.match(cell):
                    shown = cell.strip() if len(cell) <= 40 else cell.strip()[:30] + f"... ({len(cell)} characters)"
                    raise UserError(f"{path}:{line}:{c + 1}: column {header[c]!r}: expected a number, found {shown!r}")
        raise UserError(f"{path}:{numbers[0]}: cannot read the rows from here on as numbers")
    bad = np.argwhere(~np.isfinite(block))
    if len(bad):
        r, c = bad[0]
        cell = _fields(path, numbers[r], text_lines[r], delimiter)[c]
        raise UserError(f"{path}:{numbers[r]}:{c + 1}: column {header[c]!r}: expected a finite number, "
                        f"found {cell.strip()!r}")
    return block


def _read_npz(path: str, time_column: str | None) -> Table:
    """Columns stored with numpy.savez: the fast way in for very long recordings."""
    try:
        with open(path, "rb") as f:
            magic = f.read(4)
    except OSError as exc:
        raise UserError(f"{path}: cannot read: {exc.strerror}") from None
    if magic != b"PK\x03\x04":
        raise UserError(f"{path}: not a .npz archive (it does not start as a zip file); a CSV file must not end in .npz")
    try:
        with zipfile.ZipFile(path) as archive:
            unpacked = sum(info.file_size for info in archive.infolist())
    except (OSError, zipfile.BadZipFile) as exc:
        raise UserError(f"{path}: cannot read as .npz: {exc}") from None
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    if 2 * unpacked > memory:  # the columns are held as float64: up to twice the stored size
        raise UserError(f"{path}: the archive unpacks to {unpacked / 2 ** 30:.1f} GiB; this machine has "
                        f"{memory / 2 ** 30:.1f} GiB of memory (a zip bomb, or split the recording)")
    try:
        with np.load(path, allow_pickle=False) as archive:
            columns = {name: np.asarray(archive[name]) for name in archive.files}
    except (OSError, ValueError) as exc:
        raise UserError(f"{path}: cannot read as .npz: {exc}") from None
    if not columns:
        raise UserError(f"{path}: the archive holds no columns")
    lengths = {name: a.shape for name, a in columns.items()}
    if any(len(shape) != 1 for shape in lengths.values()) or len({s[0] for s in lengths.values()}) != 1:
        raise UserError(f"{path}: every array must be one column of the same length; found "
                        + ", ".join(f"{n} {s}" for n, s in lengths.items()))
    for name, a in columns.items():
        if a.dtype.kind not in "iuf":
            raise UserError(f"{path}: column {name!r} holds {a.dtype}, expected numbers")
        columns[name] = a.astype(np.float64)
        bad = np.nonzero(~np.isfinite(columns[name]))[0]
        if len(bad):
            raise UserError(f"{path}: column {name!r} row {bad[0] + 1}: expected a finite number, found {a[bad[0]]!r}")
    if not len(next(iter(columns.values()))):
        raise UserError(f"{path}: no data rows")
    table = Table(path, columns, _sha256(path), np.arange(1, len(next(iter(columns.values()))) + 1))
    _check_time(table, time_column, list(columns))
    return table


def _check_time(table: Table, time_column: str | None, header: list[str]) -> None:
    if time_column is None:
        return
    if time_column not in table.columns:
        raise UserError(f"{table.path}: no time column {time_column!r} (set it with --time); "
                        f"the header has {', '.join(header)}")
    t = table.columns[time_column]
    bad = np.nonzero(np.diff(t) <= 0)[0]
    if len(bad):
        line = int(table.lines[bad[0] + 1])
        raise UserError(f"{table.path}:{line}: column {time_column!r}: time must increase strictly, "
                        f"found {t[bad[0] + 1]:g} after {t[bad[0]]:g}")


def _delimiter(path: str, header_line: str, decimal: str) -> tuple[str, bool]:
    """',' with decimal points, or ';' (German Excel exports) where a comma can only be a decimal comma."""
    has_comma, has_semicolon = "," in header_line, ";" in header_line
    if has_comma and has_semicolon:
        raise UserError(f"{path}:1: the header has both ',' and ';': cannot tell which one separates the columns")
    if has_semicolon:
        if decimal == ".":
            return ";", False
        return ";", True
    if decimal == ",":
        raise UserError(f"{path}:1: --decimal , needs ';' between the columns, but the header is separated by ','")
    return ",", False


def read_table(path: str | Path, time_column: str | None = "time_s", progress=None, decimal: str = "auto") -> Table:
    """Read a CSV file with one header line (or a .npz of columns); every cell must be a finite
    number. ',' separated with decimal points, or ';' separated with decimal commas (detected, or
    decimal=','). The text is streamed in chunks, so memory stays near the size of the numbers."""
    path = str(path)
    if path.lower().endswith(".npz"):
        return _read_npz(path, time_column)
    digest = hashlib.sha256()
    try:
        raw = open(path, "rb")
    except OSError as exc:
        raise UserError(f"{path}: cannot read: {exc.strerror}") from None
    handle = io.TextIOWrapper(io.BufferedReader(_Hashing(raw, digest)), encoding="utf-8-sig", newline=None)
    blocks, numbers_all = [], []
    text_lines, numbers = [], []
    line = 0

    def flush() -> None:
        blocks.append(_parse_cells(path, header, text_lines, numbers, delimiter, comma_decimal))
        numbers_all.append(np.asarray(numbers, np.int64))

    try:
        with handle:
            first = handle.readline()
            line = 1
            if not first.strip():
                if handle.read(1):
                    raise UserError(f"{path}:1: the first line is blank; expected the header (the column names) there")
                raise UserError(f"{path}: file is empty; expected a header line and data rows")
            if first.lstrip().startswith("#"):
                raise UserError(f"{path}:1: a comment line; expected the header (the column names) on the first line")
            delimiter, comma_decimal = _delimiter(path, first, decimal)
            header = [h.strip() for h in _fields(path, 1, first, delimiter)]
            seen = set()
            for col, name in enumerate(header, start=1):
                if not name:
                    raise UserError(f"{path}:1:{col}: empty column name in the header")
                if name in seen:
                    raise UserError(f"{path}:1:{col}: column {name!r} appears twice in the header")
                seen.add(name)
            total = 0
            for text in handle:
                line += 1
                if not text.strip().strip(delimiter).strip():
                    continue
                text_lines.append(text)
                numbers.append(line)
                if len(text_lines) == CHUNK_ROWS:
                    flush()
                    total += len(text_lines)
                    text_lines, numbers = [], []
                    if progress is not None and total % PROGRESS_ROWS < CHUNK_ROWS:
                        progress(f"read {total:,} rows of {Path(path).name}")
            if text_lines:
                flush()
    except UnicodeDecodeError as exc:
        raise UserError(f"{path}:{line + 1}: not a UTF-8 text file (byte {exc.object[exc.start]:#04x})") from None
    if not blocks:
        raise UserError(f"{path}: header only, no data rows")
    values = np.concatenate(blocks) if len(blocks) > 1 else blocks[0]
    blocks.clear()  # frees the chunks before the columns are copied out
    columns = {name: np.ascontiguousarray(values[:, i]) for i, name in enumerate(header)}
    del values
    table = Table(path, columns, digest.hexdigest(), np.concatenate(numbers_all))
    _check_time(table, time_column, header)
    return table


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
