"""A recording read chunk by chunk for `verify` (any length in bounded memory): the named columns of a
CSV (parsed by recordings/plain_csv or pyarrow, a block ahead on a thread), .npz or Parquet file, each
file accepted exactly when recordings/table.py's careful reader accepts it; anything else declines
(CannotStream) and the careful reader decides and words the error."""
from __future__ import annotations

import os
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from thermoplc.base import compiled
from thermoplc.base.errors import UserError
from thermoplc.base.locations import open_binary
from thermoplc.recordings import plain_csv
from thermoplc.recordings.read_ahead import read_ahead
from thermoplc.recordings.cells import csv_fields
from thermoplc.recordings.formats import CannotStream, format_of
from thermoplc.recordings.table import csv_delimiter, spellings

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
# blocks of at least this much text are first offered to recordings/plain_csv (numba; a process that reads this much
# loads numba for the references anyway), smaller ones go to pyarrow at once
PLAIN_PARSE_BYTES = 4 << 20


@dataclass(frozen=True)
class Chunk:
    start: int  # row number of the first row in the recording (0-based)
    columns: dict  # name -> float64 array

    @property
    def rows(self) -> int:
        return len(next(iter(self.columns.values())))


def stream_columns(path: str | Path, names: list[str], decimal: str = "auto", rows_per_chunk: int = STREAM_ROWS,
                   optional: tuple[str, ...] = ()):
    """Chunks of the named columns (float64), in order. Every column of the file is checked as
    read_table checks it (finite numbers), so the file is accepted exactly when read_table accepts
    it; only `names` (and those of `optional` the file has, in any case) are kept. Raises CannotStream instead
    of any error."""
    stored = format_of(path)
    try:
        if stored is not None:
            start = 0
            for columns in stored.chunks(str(path), rows_per_chunk):
                _finite_numbers(columns)
                yield _keep(columns, names, start, optional)
                start += len(next(iter(columns.values())))
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
        delimiter, comma_decimal = csv_delimiter(path, text, decimal)
        header = [h.strip() for h in csv_fields(path, 1, text, delimiter)]
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
