"""Reading recorded data (CSV) into named float64 columns, with errors that point at the cell."""
from __future__ import annotations

import csv
import hashlib
import io
import os
import re
import sys
import unicodedata
import zipfile
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from thermoplc.base.binary32 import FLT_MAX, f32_from_bits
from thermoplc.base.errors import UserError, unreadable
from thermoplc.base.locations import name as location_name, open_binary
from thermoplc.base import compiled
from thermoplc.recordings import plain_csv
from thermoplc.recordings.read_ahead import read_ahead


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

    @property
    def rows(self) -> int:
        return len(next(iter(self.columns.values())))

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


NUMBER = re.compile(r"\s*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\s*$|\s*[+-]?(nan|inf|infinity)\s*$",
                    re.IGNORECASE | re.ASCII)


# a REAL written as its 32 bits, as a PLC trace exports a DWORD: TIA's 16#3F80_0000, STEP 7's
# DW#16#3F800000 or C's 0x3F800000
BINARY32_BITS = re.compile(r"\s*(?:(?:DW#)?16#|0x)([0-9A-F]{4})_?([0-9A-F]{4})\s*$", re.ASCII | re.IGNORECASE)


def _cell_value(cell: str) -> float | None:
    """A cell's number: decimal, or the binary32 value of 8 hexadecimal digits; None if neither."""
    if NUMBER.match(cell):
        return float(cell)
    bits = BINARY32_BITS.match(cell)
    return f32_from_bits(int(bits.group(1) + bits.group(2), 16)) if bits else None


def _fields(path: str, line: int, text: str, delimiter: str) -> list[str]:
    """One line's fields; a quote that never closes or a field beyond the csv module's limit is named."""
    try:
        return next(csv.reader([text], delimiter=delimiter), [])
    except csv.Error as exc:
        raise UserError(f"{path}:{line}: cannot split the line into fields ({exc}); expected numbers separated by "
                        f"{delimiter!r}") from None


def _parse_cells(path: str, header: list[str], text_lines: list[str], numbers: list[int], delimiter: str,
                 comma_decimal: bool, sparse: frozenset = frozenset()) -> np.ndarray:
    """Rows of numbers; the fast C parser first, the careful one for the message when it fails. An empty
    cell of a `sparse` column (a probed target between its measurements) is NaN; anywhere else, and a
    NaN written out anywhere, is refused."""
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
        block, empty = _parse_cells_one_by_one(path, header, written, numbers, delimiter, sparse, comma_decimal)
    bad = np.argwhere(~np.isfinite(block) & ~empty)
    if len(bad):
        r, c = bad[0]
        cell = _fields(path, numbers[r], written[r], delimiter)[c]
        raise UserError(f"{path}:{numbers[r]}:{c + 1}: column {header[c]!r}: expected a finite number, "
                        f"found {cell.strip()!r}")
    return block


def _refuse_points(path: str, header: list[str], text_lines: list[str], numbers: list[int], delimiter: str) -> None:
    """In a file of decimal commas a '.' is a thousands separator (7.500 rpm) or a decimal point of another
    convention: either way not a number this reader may guess, so it is named where it is, as written."""
    for line, text in zip(numbers, text_lines):
        if "." in text:
            fields = _fields(path, line, text, delimiter)
            for column, cell in enumerate(fields if len(fields) == len(header) else ()):  # else: the count is named
                if "." in cell:
                    raise UserError(f"{path}:{line}:{column + 1}: column {header[column]!r}: {cell.strip()!r} has a "
                                    f"'.' in a file read with decimal commas (';' between the columns); expected "
                                    f"a number such as 7500 or 21,5 (no thousands separator), or --decimal . if "
                                    f"the file's decimals are points")


def _parse_cells_one_by_one(path: str, header: list[str], text_lines: list[str], numbers: list[int],
                            delimiter: str, sparse: frozenset, comma_decimal: bool) -> tuple[np.ndarray, np.ndarray]:
    """The rows the C parser refused: binary32 bit patterns are read here, an empty cell of a sparse column
    is NaN (and marked in the second array), anything else is named as written."""
    block = np.empty((len(text_lines), len(header)))
    empty = np.zeros(block.shape, bool)
    for r, (line, text) in enumerate(zip(numbers, text_lines)):
        row = _fields(path, line, text, delimiter)
        if len(row) != len(header):
            quote = " (a '\"' opens a quoted field that runs to the end of the line)" if '"' in text else ""
            raise UserError(f"{path}:{line}: {len(row)} fields, expected {len(header)} as in the header{quote}")
        for c, cell in enumerate(row):
            if not cell.strip() and header[c] in sparse:
                block[r, c], empty[r, c] = np.nan, True
                continue
            value = _cell_value(cell.replace(",", ".") if comma_decimal else cell)
            if value is None:
                shown = cell.strip(" \t") if len(cell) <= 40 else cell.strip(" \t")[:30] + f"... ({len(cell)} characters)"
                hint = " (a REAL's 32 bits are 8 hexadecimal digits: 16#3F800000 or 0x3F800000)" \
                    if cell.strip().lower().startswith(("0x", "16#", "dw#")) else \
                    " (a runs table? give it as --runs TABLE)" if header[c] == "file" else ""
                raise UserError(f"{path}:{line}:{c + 1}: column {header[c]!r}: expected a number, found "
                                f"{shown!r}{hint}")
            block[r, c] = value
    return block, empty


def _read_npz(path: str, time_column: str | None, sparse: frozenset = frozenset()) -> Table:
    """Columns stored with numpy.savez: the fast way in for very long recordings."""
    try:
        with open_binary(path) as f:
            magic = f.read(4)
    except OSError as exc:
        raise unreadable(path, exc) from None
    if magic != b"PK\x03\x04":
        raise UserError(f"{path}: not a .npz archive (it does not start as a zip file); a CSV file must not end in .npz")
    try:
        with open_binary(path) as f, zipfile.ZipFile(f) as archive:
            unpacked = sum(info.file_size for info in archive.infolist())
    except (OSError, zipfile.BadZipFile) as exc:
        raise UserError(f"{path}: cannot read as .npz: {exc}") from None
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    if 2 * unpacked > memory:  # the columns are held as float64: up to twice the stored size
        raise UserError(f"{path}: the archive unpacks to {unpacked / 2 ** 30:.1f} GiB; this machine has "
                        f"{memory / 2 ** 30:.1f} GiB of memory (a zip bomb, or split the recording)")
    try:
        with open_binary(path) as f, np.load(f, allow_pickle=False) as archive:
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
        if a.dtype.kind not in "biuf":  # bool: the natural type of a recorded Enable or Reset
            raise UserError(f"{path}: column {name!r} holds {a.dtype}, expected numbers")
        columns[name] = a.astype(np.float64)
        bad = np.nonzero(~np.isfinite(columns[name]) & ~(np.isnan(columns[name]) & (name in sparse)))[0]
        if len(bad):
            raise UserError(f"{path}: column {name!r} row {bad[0] + 1}: expected a finite number, found {a[bad[0]]}")
    if not len(next(iter(columns.values()))):
        raise UserError(f"{path}: no data rows")
    table = Table(path, columns, sha256_of(path), np.arange(1, len(next(iter(columns.values()))) + 1))
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


def _header(path: str, first: str, decimal: str) -> tuple[str, bool, list[str]]:
    """The delimiter, whether decimals are commas, and the column names of header line `first`; refuses a
    comment line, an empty column name and a name given twice, by line and column."""
    if first.lstrip().startswith("#"):
        raise UserError(f"{path}:1: a comment line; expected the header (the column names) on the first line")
    delimiter, comma_decimal = _delimiter(path, first, decimal)
    header = [h.strip() for h in _fields(path, 1, first, delimiter)]
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


def read_table(path: str | Path, time_column: str | None = "time_s", progress=None, decimal: str = "auto",
               sparse: tuple[str, ...] = ()) -> Table:
    """Read a CSV file with one header line (or a .npz of columns); every cell must be a finite
    number, but for the `sparse` columns (a probed target), whose empty cells (NaN in .npz/.parquet) read
    as NaN. ',' separated with decimal points, or ';' separated with decimal commas (detected, or
    decimal=','). The text is streamed in chunks, so memory stays near the size of the numbers."""
    path = str(path)
    kind = stream_kind(path)
    if kind == "npz":
        return _read_npz(path, time_column, frozenset(sparse))
    if kind == "parquet":
        return _read_parquet(path, time_column, frozenset(sparse))
    digest = hashlib.sha256()
    try:
        raw = sys.stdin.buffer if path == "-" else open_binary(path)  # `--data -`: the CSV on standard input
    except OSError as exc:
        raise unreadable(path, exc) from None
    path = "<stdin>" if path == "-" else path
    handle = io.TextIOWrapper(io.BufferedReader(_Hashing(raw, digest)), encoding="utf-8-sig", newline=None)
    blocks, numbers_all = [], []
    text_lines, numbers = [], []
    line = 0

    def flush() -> None:
        blocks.append(_parse_cells(path, header, text_lines, numbers, delimiter, comma_decimal, frozenset(sparse)))
        numbers_all.append(np.asarray(numbers, np.int64))

    try:
        with handle:
            first = handle.readline()
            line = 1
            if not first.strip():
                if handle.read(1):
                    raise UserError(f"{path}:1: the first line is blank; expected the header (the column names) there")
                raise UserError(f"{path}: file is empty; expected a header line and data rows")
            delimiter, comma_decimal, header = _header(path, first, decimal)
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


# ---------------------------------------------------------------------------------------------
# Streaming at disk speed (issue 17). The fast readers below hand out the columns chunk by chunk
# and never word an error: anything they do not take in their stride (a cell that is not a
# plain number, a blank line, a NaN, time not increasing, an odd line ending, a file they cannot
# open) raises CannotStream, and the caller reads the file again with read_table, whose messages
# name the file, line and column. So a file is accepted by the streaming path only when every
# row parsed as a finite number, with the row count checked against the line count: no row is
# ever dropped silently.

STREAM_ROWS = 1 << 20  # rows per chunk
STREAM_BYTES = 16 << 20  # CSV text read at once (larger blocks parse slower: caches)
# ... parsed by pyarrow in pieces of this size on every core (its thread pool): lines never span two pieces
# (no newline inside a value), and the pieces are joined in order, so the columns are those of one thread
CSV_PARSE_BYTES = 4 << 20
# blocks of at least this much text are first offered to models/plain_csv (numba; a process that reads this much
# loads numba for the references anyway), smaller ones go to pyarrow at once
PLAIN_PARSE_BYTES = 4 << 20


class CannotStream(Exception):
    """The fast reader declines this file (the careful reader decides, and words any error)."""


@dataclass(frozen=True)
class Chunk:
    start: int  # row number of the first row in the recording (0-based)
    columns: dict  # name -> float64 array

    @property
    def rows(self) -> int:
        return len(next(iter(self.columns.values())))


def stream_kind(path: str | Path) -> str:
    lower = location_name(str(path)).lower()  # a URL's query is no part of its name
    return "npz" if lower.endswith(".npz") else "parquet" if lower.endswith(".parquet") else "csv"


def stream_columns(path: str | Path, names: list[str], decimal: str = "auto", rows_per_chunk: int = STREAM_ROWS,
                   optional: tuple[str, ...] = ()):
    """Chunks of the named columns (float64), in order. Every column of the file is checked as
    read_table checks it (finite numbers), so the file is accepted exactly when read_table accepts
    it; only `names` (and those of `optional` the file has, in any case) are kept. Raises CannotStream instead
    of any error."""
    kind = stream_kind(path)
    try:
        if kind == "npz":
            yield from _stream_npz(str(path), names, rows_per_chunk, optional)
        elif kind == "parquet":
            yield from _stream_parquet(str(path), names, rows_per_chunk, optional)
        else:
            for chunks in read_ahead(lambda: _stream_csv(str(path), names, decimal, optional)):
                yield from chunks
    except CannotStream:
        raise
    except (UserError, OSError, ValueError, EOFError, zipfile.BadZipFile, ImportError) as exc:
        raise CannotStream(str(exc)) from None
    except Exception as exc:  # pyarrow's own errors: the careful reader says what is wrong
        raise CannotStream(f"{type(exc).__name__}: {exc}") from None


def _finite_numbers(columns: dict) -> None:
    for a in columns.values():
        if a.dtype.kind not in "iuf" or a.ndim != 1:
            raise CannotStream("not a column of numbers")
        if a.dtype.kind == "f" and not np.isfinite(a).all():
            raise CannotStream("a cell is not a finite number")


def spellings(columns, name: str) -> list[str]:
    """Every column named `name` in any case (a block input's name: ST names ignore case)."""
    return [column for column in columns if column.upper() == name.upper()]


def columns_named(columns, name: str) -> list[str]:
    """The column `name`, else every column named so in another case (a block input's column: ST names
    ignore case): one is the column, more are ambiguous, none means no column."""
    if name in columns:
        return [name]
    return spellings(columns, name)


def _keep(columns: dict, names: list[str], start: int, optional: tuple[str, ...] = ()) -> Chunk:
    """The chunk of `names`, and of each `optional` name the file has in any case, kept under the name
    asked for (a block input's name ignores case, so two spellings of it are refused)."""
    missing = [n for n in names if n not in columns]
    if missing:
        raise CannotStream(f"no column {missing[0]!r}")
    kept = {n: columns[n] for n in names}
    for name in optional:
        found = spellings(columns, name)  # two spellings of an input's name are two columns
        if len(found) > 1:
            raise CannotStream(f"two columns could be {name}")
        if found and name not in kept:
            kept[name] = columns[found[0]]
    return Chunk(start, {n: np.asarray(values, np.float64) for n, values in kept.items()})


def _stream_csv(path: str, names: list[str], decimal: str, optional: tuple[str, ...] = ()):
    """The chunks of each block of the CSV text, a list per block."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    pa.set_cpu_count(_usable_cores())  # Arrow sizes its pool by OMP_NUM_THREADS, which thermoplc sets to 1 for BLAS

    with open_binary(path) as f:
        head = f.readline()
        if not head.endswith(b"\n"):
            raise CannotStream("header only")
        text = head.decode("utf-8-sig")
        if not text.strip() or text.lstrip().startswith("#") or "\r" in text.rstrip("\r\n"):
            raise CannotStream("not a plain header")
        delimiter, comma_decimal = _delimiter(path, text, decimal)
        header = [h.strip() for h in _fields(path, 1, text, delimiter)]
        if not all(header) or len(set(header)) != len(header) or not all(name.isprintable() for name in header):
            raise CannotStream("header needs the careful reader")
        point = "," if comma_decimal else "."
        options = dict(
            read_options=pacsv.ReadOptions(column_names=header, use_threads=True, block_size=CSV_PARSE_BYTES),
            parse_options=pacsv.ParseOptions(delimiter=delimiter, quote_char='"', newlines_in_values=False,
                                             ignore_empty_lines=False),
            convert_options=pacsv.ConvertOptions(column_types={h: pa.float64() for h in header},
                                                 decimal_point=point, quoted_strings_can_be_null=False))
        plain = compiled.could_compile()
        keep = [h in names or any(h.upper() == name.upper() for name in optional) for h in header]
        # one buffer for every block, read into in place: a fresh 16 MiB object per block costs more in page faults
        # than the parsing of it; the unfinished last line of a block moves to the buffer's start
        room = STREAM_BYTES + plain_csv.PADDING + 1  # a block, the parser's padding, the last line's line feed
        buffer, kept, total = bytearray(room), 0, 0
        while True:
            if len(buffer) < kept + room:  # a line longer than a block
                buffer = buffer[:kept] + bytearray(room)
            got = _read_into(f, memoryview(buffer)[kept:kept + STREAM_BYTES])
            last = got == 0
            size = kept + got
            if not last:
                cut = buffer.rfind(b"\n", 0, size) + 1
                end = _content_end(buffer, cut)  # trailing blank lines wait for the next block or the end
                if end == 0:
                    kept = size
                    continue
                end = buffer.index(b"\n", end, size) + 1
            else:
                end = _content_end(buffer, size)  # blank lines at the end: read_table skips them too
                if end == 0:
                    break
                buffer[end] = plain_csv.NEWLINE  # the last line's
                end += 1
            parts = None
            if plain and end >= PLAIN_PARSE_BYTES and plain_csv.available():
                # one part more than the cores: the parsing threads, with more work than the thread verifying the last
                # block, then get about two thirds of the cores instead of half (a year of CSV: 7.3-7.7 s -> 6.7-7.0 s)
                parts = plain_csv.parse_block(buffer, end, keep, delimiter, point, _usable_cores() + 1)
            if parts is None:
                columns = _parse_block(pacsv, pa, buffer, end, header, options)
                parts = [(len(columns[header[0]]), columns)]
            else:  # the other columns were checked, not kept
                kept_names = [h for h, k in zip(header, keep) if k]
                parts = [(part.shape[1], dict(zip(kept_names, part))) for part in parts]
            lines, chunks = 0, []
            for rows, columns in parts:
                for at in range(0, rows, STREAM_ROWS):  # bounded chunks, whatever the block held
                    piece = {h: c[at:at + STREAM_ROWS] for h, c in columns.items()}
                    chunks.append(_keep(piece, names, total + lines + at, optional))
                lines += rows
            yield chunks  # a block's chunks at once: read_ahead's one item ahead is then a whole block
            total += lines
            if last:
                break
            buffer[:size - end] = buffer[end:size]
            kept = size - end
        if total == 0:
            raise CannotStream("no data rows")


def _parse_block(pacsv, pa, data: bytes, end: int, header: list[str], options: dict) -> dict:
    """The columns of the lines data[:end] by pyarrow's reader; CannotStream for anything the careful reader must
    word."""
    if data.find(b"\xef\xbb\xbf", 0, end) >= 0:  # pyarrow skips a byte-order mark opening any buffer it reads
        raise CannotStream("a byte-order mark after the header")
    returns = data.find(b"\r", 0, end) >= 0
    if returns and data.count(b"\r", 0, end) != data.count(b"\r\n", 0, end):
        raise CannotStream("a line ends in a bare carriage return")
    table = pacsv.read_csv(pa.BufferReader(pa.py_buffer(data)[:end]), **options)
    # without a quote or a carriage return every line is one row (a blank one a row of empty cells,
    # refused below): the lines are counted only where a quoted field could hold a line end
    lines = data.count(b"\n", 0, end) if returns or data.find(b'"', 0, end) >= 0 else table.num_rows
    if table.num_rows != lines or table.num_columns != len(header):
        raise CannotStream("rows and lines differ")
    if any(c.null_count for c in table.columns):
        raise CannotStream("an empty cell or a blank line")
    columns = {h: table.column(h).to_numpy() for h in header}
    del table
    _finite_numbers(columns)
    return columns


def _read_into(f, view: memoryview) -> int:
    """Bytes read into `view`: as many as fit, fewer only at the end of the file."""
    got = 0
    while got < len(view):
        n = f.readinto(view[got:])
        if not n:
            break
        got += n
    return got


def _usable_cores() -> int:
    """The cores this process may run on (its affinity), for pyarrow's parsing threads."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # not Linux
        return max(os.cpu_count() or 1, 1)


def _content_end(data: bytes, end: int) -> int:
    """Where the text before `end` stops, blanks and line ends after it left out (0: only blanks)."""
    while end > 0 and data[end - 1] in b" \t\r\n":
        end -= 1
    return end


def _npy_header(member) -> tuple[tuple, np.dtype]:
    version = np.lib.format.read_magic(member)
    if version == (1, 0):
        shape, fortran, dtype = np.lib.format.read_array_header_1_0(member)
    elif version == (2, 0):
        shape, fortran, dtype = np.lib.format.read_array_header_2_0(member)
    else:
        raise CannotStream(f"npy format {version}")
    if dtype.hasobject or dtype.kind not in "iuf" or len(shape) != 1:
        raise CannotStream("not a column of numbers")
    return shape, dtype


def _stream_npz(path: str, names: list[str], rows_per_chunk: int, optional: tuple[str, ...] = ()):
    with open_binary(path) as f:
        if f.read(4) != b"PK\x03\x04":
            raise CannotStream("not a zip file")
    with open_binary(path) as f, zipfile.ZipFile(f) as archive:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        if 2 * sum(info.file_size for info in archive.infolist()) > memory:
            raise CannotStream("larger than memory")
        members = {}
        try:
            for info in archive.infolist():
                if not info.filename.endswith(".npy"):
                    raise CannotStream("not an array")
                member = archive.open(info)
                members[info.filename[:-4]] = (member, *_npy_header(member))
            if not members or len({shape for _, shape, _ in members.values()}) != 1:
                raise CannotStream("columns of different lengths")
            rows = next(iter(members.values()))[1][0]
            if rows == 0:
                raise CannotStream("no data rows")
            for start in range(0, rows, rows_per_chunk):
                n = min(rows_per_chunk, rows - start)
                columns = {}
                for name, (member, _, dtype) in members.items():
                    raw = member.read(n * dtype.itemsize)
                    if len(raw) != n * dtype.itemsize:
                        raise CannotStream("truncated array")
                    columns[name] = np.frombuffer(raw, dtype)
                _finite_numbers(columns)
                yield _keep(columns, names, start, optional)
        finally:
            for member, *_ in members.values():
                member.close()


def _stream_parquet(path: str, names: list[str], rows_per_chunk: int, optional: tuple[str, ...] = ()):
    import pyarrow.parquet as pq

    with open_binary(path) as f, pq.ParquetFile(f, pre_buffer=False, buffer_size=1 << 20) as pf:
        if pf.metadata.num_rows == 0:
            raise CannotStream("no data rows")
        start = 0
        for batch in pf.iter_batches(batch_size=rows_per_chunk, use_threads=False):
            if any(c.null_count for c in batch.columns):
                raise CannotStream("an empty cell")
            columns = {n: batch.column(n).to_numpy(zero_copy_only=False) for n in batch.schema.names}
            _finite_numbers(columns)
            yield _keep(columns, names, start, optional)
            start += batch.num_rows


def _read_parquet(path: str, time_column: str | None, sparse: frozenset = frozenset()) -> Table:
    """Columns of a Parquet file (pyarrow): numbers only, no empty cells but in the `sparse` columns."""
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise UserError(f"{path}: reading Parquet needs pyarrow (pip install pyarrow)") from None
    try:
        with open_binary(path) as f:
            table = pq.read_table(f)
    except OSError as exc:
        raise UserError(f"{path}: cannot read as Parquet: {exc}") from None
    except Exception as exc:
        raise UserError(f"{path}: cannot read as Parquet: {exc}") from None
    if table.num_columns == 0:
        raise UserError(f"{path}: the file holds no columns")
    if table.num_rows == 0:
        raise UserError(f"{path}: no data rows")
    columns = {}
    for name in table.column_names:
        column = table.column(name)
        if column.null_count and name not in sparse:
            row = int(np.flatnonzero(column.is_null().to_numpy(zero_copy_only=False))[0])
            raise UserError(f"{path}: column {name!r} row {row + 1}: expected a finite number, found an empty cell")
        a = column.to_numpy()
        if a.dtype.kind not in "iuf":
            raise UserError(f"{path}: column {name!r} holds {column.type}, expected numbers")
        columns[name] = a.astype(np.float64)
        bad = np.nonzero(~np.isfinite(columns[name]) & ~(np.isnan(columns[name]) & (name in sparse)))[0]
        if len(bad):
            raise UserError(f"{path}: column {name!r} row {bad[0] + 1}: expected a finite number, found {a[bad[0]]!r}")
    result = Table(path, columns, sha256_of(path), np.arange(1, table.num_rows + 1))
    _check_time(result, time_column, list(columns))
    return result
