"""Reading recorded data (CSV) into named float64 columns, with errors that point at the cell."""
from __future__ import annotations

import functools
import hashlib
import io
import re
import shlex
import sys
import unicodedata
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from thermoplc.base.binary32 import FLT_MAX
from thermoplc.base.errors import UserError, unreadable
from thermoplc.base.locations import name as location_name, open_binary
from thermoplc.recordings.cells import MISSING, cell_value, csv_fields, parse_cells
from thermoplc.recordings.formats import format_of
from thermoplc.recordings.gaps import apply_gaps
from thermoplc.recordings.layout import Layout
from thermoplc.recordings.reading import Reading
from thermoplc.recordings.timestamps import excel_seconds


CHUNK_ROWS = 65536  # rows parsed at once: bounds the memory of the text being parsed
PROGRESS_ROWS = 1_000_000


def close_match(name: str, names) -> str:
    """' (did you mean X?)' for the column most like a misspelled `name` (case first, then spelling), or ''."""
    import difflib
    names = list(names)
    same = [n for n in names if n.casefold() == name.casefold()]
    found = same or difflib.get_close_matches(name, names, n=1, cutoff=0.6)
    return f" (did you mean {found[0]!r}?)" if found else ""


@dataclass(frozen=True)
class Table:
    path: str
    columns: dict  # name -> float64 array
    sha256: str
    lines: np.ndarray  # line number in the file of each row (for .npz: the row number)
    read_notes: tuple[str, ...] = ()  # what the reader converted (date-times, a units row), for the user to see
    reading: Reading = Reading()  # how the text was read (a model fitted on it records this)

    @property
    def rows(self) -> int:
        return len(next(iter(self.columns.values())))

    @functools.cached_property
    def content_sha256(self) -> str:
        """The sha256 of what the recording holds, not of its bytes: every column's name and float64 values, the
        columns in name order, NaN and -0.0 written one way each. The same run as CSV or Parquet, with other line
        endings, quoting, number spellings or column order has the same digest (a copy is no held-out run)."""
        digest = hashlib.sha256()
        for name in sorted(self.columns):
            values = np.asarray(self.columns[name], dtype=np.float64) + 0.0  # -0.0 + 0.0 is +0.0
            values = np.where(np.isnan(values), np.nan, values)  # one NaN, whatever its payload
            digest.update(name.encode("utf-8") + b"\0" + len(values).to_bytes(8, "little"))
            digest.update(np.ascontiguousarray(values).astype("<f8").tobytes())
        return digest.hexdigest()

    def column(self, name: str) -> np.ndarray:
        if name not in self.columns:
            raise UserError(f"{self.path}: no column {name!r}{close_match(name, self.columns)}; the header has "
                            f"{', '.join(self.columns)}")
        return self.columns[name]

    def head(self, rows: int) -> Table:
        """The first `rows` rows, as a recording that stopped there (a fold's training part)."""
        return replace(self, columns={c: v[:rows] for c, v in self.columns.items()}, lines=self.lines[:rows])

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


def sha256_of(path: str) -> str:
    """The sha256 of a recording's bytes (a file or an object-store URL); OSError when it cannot be read."""
    digest = hashlib.sha256()
    with open_binary(path) as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def bundled_hint(path: str) -> str:
    """Where thermoplc's own copy of a recording it ships is, when the one asked for is not where the user stands (the
    docs' bare fl_thermal.csv)."""
    import importlib.resources
    shipped = importlib.resources.files("thermoplc") / "data" / "fl_thermal" / "fl_thermal.csv"
    if Path(str(path)).name != shipped.name or Path(str(path)).exists():
        return ""
    return f" (thermoplc ships a copy: {shipped}; copy it here with its LICENSE, or give that path)"


def _refuse_no_time(path: str, time_column: str, header: list[str]) -> None:
    """A missing time column named before any row is read, with the header's one time-like column suggested."""
    if time_column not in header and "file" in header:
        raise UserError(f"{path}: no time column {time_column!r}, and a column 'file': a runs table? give it as "
                        f"--runs TABLE")
    if time_column not in header:
        timed = [name for name in header if re.search(r"time|zeit|date|datum|stamp", name, re.IGNORECASE)]
        clocks = [name for name in timed if not re.search(r"date|datum", name, re.IGNORECASE)]
        hint = f": --time {shlex.quote(timed[0])}" if len(timed) == 1 else \
            f": --time {shlex.quote(clocks[0])}, the date column beside it is joined" if len(timed) == 2 and \
            len(clocks) == 1 else ""
        raise UserError(f"{path}: no time column {time_column!r} (set it with --time{hint}); "
                        f"the header has {', '.join(header)}")


def _check_time(table: Table, time_column: str | None, header: list[str], dated: bool | None = None) -> None:
    """Time strictly increasing; `dated`: the column was date-times, with their UTC offsets (True) or without."""
    if time_column is None:
        return
    _refuse_no_time(table.path, time_column, header)
    t = table.columns[time_column]
    bad = np.nonzero(np.diff(t) <= 0)[0]
    if len(bad):
        line = int(table.lines[bad[0] + 1])
        if dated is not None and t[bad[0] + 1] == t[bad[0]]:
            raise UserError(f"{table.path}:{line}: column {time_column!r}: the same time as the row before; expected "
                            f"times that increase (export the times with fractions of a second, or one row per time)")
        if dated is not None:
            why = ("a logger reset or rows out of order" if dated else
                   "a daylight-saving change written without its UTC offset, or a logger reset")
            advice = "" if dated else ": export the times with their UTC offset (2024-10-27T02:30:00+01:00) or in UTC"
            raise UserError(f"{table.path}:{line}: column {time_column!r}: the clock goes back "
                            f"{t[bad[0]] - t[bad[0] + 1]:g} s here ({why}); expected times that increase{advice}")
        raise UserError(f"{table.path}:{line}: column {time_column!r}: time must increase strictly, "
                        f"found {t[bad[0] + 1]:g} after {t[bad[0]]:g}")


def csv_delimiter(path: str, header_line: str, decimal: str) -> tuple[str, bool]:
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


def _header(path: str, first: str, decimal: str) -> tuple[str, bool, list[str]]:
    """The delimiter, whether decimals are commas, and the column names of header line `first`; refuses a
    comment line, an empty column name and a name given twice, by line and column."""
    if first.lstrip().startswith("#"):
        raise UserError(f"{path}:1: a comment line; expected the header (the column names) on the first line")
    delimiter, comma_decimal = csv_delimiter(path, first, decimal)
    header = [h.strip() for h in csv_fields(path, 1, first, delimiter)]
    seen = set()
    for col, name in enumerate(header, start=1):
        if not name:
            raise UserError(f"{path}:1:{col}: empty column name in the header")
        hidden = next((c for c in name if unicodedata.category(c) in ("Cf", "Cc", "Zl", "Zp")), None)
        if hidden is not None:
            raise UserError(f"{path}:1:{col}: column name {name!r} holds an invisible character (U+{ord(hidden):04X}); "
                            f"a block input matched by name would miss it: rename the column")
        if name in seen:
            raise UserError(f"{path}:1:{col}: column {name!r} appears twice in the header")
        seen.add(name)
    return delimiter, comma_decimal, header


def read_table(path: str | Path, time_column: str | None = "time_s", progress=None, reading: Reading = Reading(),
               sparse: tuple[str, ...] = ()) -> Table:
    """Read a CSV file with one header line (or a file of columns: recordings/formats/); every cell must be a finite
    number, but for the `sparse` columns (a probed target), whose empty cells (NaN in a file of columns) read
    as NaN, and the missing cells `reading.gaps` drops or holds. ',' separated with decimal points, or ';'
    separated with decimal commas (detected, or reading.decimal ','). The text is streamed in chunks, so memory
    stays near the size of the numbers."""
    if not isinstance(reading, Reading):
        raise UserError(f"reading: expected a thermoplc.api.Reading, found {type(reading).__name__} {reading!r:.60}")
    path = str(path)
    stored = format_of(path)
    if stored is not None:
        columns = stored.columns(path, frozenset(sparse), reading.gaps != "refuse")
        rows = len(next(iter(columns.values()), ()))
        if not rows:  # the readers refuse these in their words
            raise UserError(f"{path}: no data rows")
        table = Table(path, columns, sha256_of(path), np.arange(1, rows + 1))
        _check_time(table, time_column, list(columns))
        return _with_gaps(_numbers_in_time(table, time_column, reading), time_column, reading, frozenset(sparse))
    digest = hashlib.sha256()
    try:
        raw = sys.stdin.buffer if path == "-" else open_binary(path)  # `--data -`: the CSV on standard input
    except OSError as exc:
        raise UserError(f"{unreadable(path, exc)}{bundled_hint(path)}") from None
    path = "<stdin>" if path == "-" else path
    handle = io.TextIOWrapper(io.BufferedReader(_Hashing(raw, digest)), encoding="utf-8-sig", newline=None)
    blocks, missing_all, numbers_all = [], [], []
    gaps = reading.gaps != "refuse"
    text_lines, numbers = [], []
    line = 0
    layout = None  # the file's form, known at its first data line

    def flush() -> None:
        block, missing = parse_cells(path, header, text_lines, numbers, delimiter, comma_decimal, frozenset(sparse),
                                      gaps)
        blocks.append(block)
        missing_all.append(missing)
        numbers_all.append(np.asarray(numbers, np.int64))

    try:
        with handle:
            first = handle.readline()
            line = 1
            if not first.strip():
                if handle.read(1):
                    raise UserError(f"{path}:1: the first line is blank; expected the header (the column names) there")
                raise UserError(f"{path}: file is empty; expected a header line and data rows")
            delimiter, comma_decimal, header = _header(path, first, reading.decimal)
            if time_column is not None:
                _refuse_no_time(path, time_column, header)
            total = 0
            for text in handle:
                line += 1
                if not text.strip().strip(delimiter).strip():
                    continue
                if layout is None:
                    numeric = lambda cell: cell_value(cell.replace(",", ".") if comma_decimal else cell) is not None
                    layout = Layout(path, header, delimiter, time_column, numeric,
                                    lambda at, written: csv_fields(path, at, written, delimiter), reading,
                                    lambda cell: gaps and cell.strip().lower() in MISSING)
                text = layout.row(line, text)
                if text is None:  # the units row
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
    missing = {}
    if gaps:
        where = np.concatenate(missing_all)
        missing = {name: where[:, i] for i, name in enumerate(header) if where[:, i].any()}
    lines = np.concatenate(numbers_all)
    notes = layout.convert(columns, lines)
    missing = {name: where for name, where in missing.items() if name in columns}  # a joined date column is gone
    columns, lines, gap_note = apply_gaps(path, columns, missing, lines, time_column, reading)
    table = Table(path, columns, digest.hexdigest(), lines, notes + ((gap_note,) if gap_note else ()), reading)
    _check_time(table, time_column, list(columns), dated=None if layout.dated is None else layout.zoned)
    return table


def _numbers_in_time(table: Table, time_column: str | None, reading: Reading) -> Table:
    """A table of columns' time column under --time-format: Excel serial days converted; a form of dates
    written as text refused (these files hold numbers)."""
    if reading.time_format == "auto" or time_column not in table.columns:
        return replace(table, reading=reading)
    if reading.time_format != "excel":
        raise UserError(f"{table.path}: --time-format {reading.time_format} reads date-times written as text; column "
                        f"{time_column!r} holds numbers (seconds, or Excel serial days with --time-format excel)")
    seconds, first = excel_seconds(table.columns[time_column], table.lines, table.path, time_column)
    note = f"{time_column}: Excel serial days read as seconds since {first.isoformat(sep=' ')} (the first row), to the millisecond"
    result = replace(table, columns={**table.columns, time_column: seconds}, read_notes=(*table.read_notes, note),
                     reading=reading)
    _check_time(result, time_column, list(result.columns))
    return result


def _with_gaps(table: Table, time_column: str | None, reading: Reading, sparse: frozenset) -> Table:
    """A table of columns under the gap rule: its NaN cells (but a sparse column's) are the missing ones."""
    if reading.gaps == "refuse":
        return replace(table, reading=reading)
    missing = {name: np.isnan(v) for name, v in table.columns.items() if name not in sparse and np.isnan(v).any()}
    columns, lines, note = apply_gaps(table.path, dict(table.columns), missing, table.lines, time_column, reading)
    result = replace(table, columns=columns, lines=lines, read_notes=table.read_notes + ((note,) if note else ()),
                     reading=reading)
    _check_time(result, time_column, list(columns))
    return result


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



def spellings(columns, name: str) -> list[str]:
    """Every column named `name` in any case (a block input's name: ST names ignore case)."""
    return [column for column in columns if column.upper() == name.upper()]


def reading_notes(tables, shown: int = 3) -> list[str]:
    """What the reader converted, a line per recording (the first `shown`, then a count), for the console."""
    lines = [f"read {location_name(table.path)}: {note}" for table in tables for note in table.read_notes]
    return lines[:shown] + ([f"... and {len(lines) - shown} more such lines"] if len(lines) > shown else [])
