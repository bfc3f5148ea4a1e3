"""An exact parser for CSV blocks of plain decimal numbers, faster than pyarrow's on this job (issue 40).

A year of 1 Hz recording is 3.2 GB of text; pyarrow's reader converts it at ~190 MB/s per core here,
so the text alone took longer than the 8 s the whole verify may take. Recordings written by loggers
and with a fixed number of decimals are plain: every cell `-?digits(.digits)?`, one delimiter between
cells, `\\n` at each line end (full-precision floats, pandas's default, are mostly not: 17 digits).
This parser takes exactly that and nothing else, at 570-650 MB/s per core (eight bytes of digits at a
time, see kernels.py); any other byte, cell or line shape makes it decline the block (`None`), and the
caller parses the block as before. So it never words an error and
never decides what a file means: it only makes the common case fast.

Every number is correctly rounded, as pyarrow's and Python's `float()` are: the digits form an integer
m <= 2**53 (exact in a double) and the point a power of ten 10**s with s <= 22 (exact too), so m / 10**s
is one IEEE division of two exact values, rounded once (Clinger's fast path). A cell outside those
bounds (more than 15-16 significant digits, more than 22 decimals) declines the block.
"""

from __future__ import annotations

import functools
import threading

import numpy as np

PADDING = 8  # bytes after the text a block's buffer must have: the parser reads 8 at a time
CELL_BYTES = 4  # bytes of text per cell assumed when sizing an output array
NEWLINE = ord("\n")


@functools.cache
def available() -> bool:
    """The compiled loops load (numba imports and compiles them, or finds them cached): the parser may be used.
    An installed numba that cannot be imported (a numpy too new for it) leaves the blocks to pyarrow."""
    try:
        import thermoplc.recordings.plain_csv.kernels  # noqa: F401
    except Exception:
        return False
    return True


def parse_lines(data: np.ndarray, start: int, stop: int, keep: list[bool], delimiter: str,
                point: str) -> list[np.ndarray] | None:
    """The numbers of the kept columns of the lines data[start:stop] (each ending in a line feed) as arrays
    [kept column, row], or None when any line is not len(keep) plain numbers. `data` is a uint8 array with PADDING
    bytes after `stop`. Each array holds the rows of about CELL_BYTES per cell (more arrays when the cells are
    shorter): small enough for malloc to reuse the last block's memory instead of faulting in fresh pages."""
    from thermoplc.recordings.plain_csv.kernels import INTEGER_POWERS, POWERS, parse_rows

    slots = np.cumsum(keep, dtype=np.int64) - 1
    slots[~np.asarray(keep, bool)] = -1
    parts = []
    while start < stop:
        out = np.empty((max(int(slots.max()) + 1, 1), (stop - start) // (CELL_BYTES * len(keep)) + 1))
        rows, start = parse_rows(data, start, stop, ord(delimiter), ord(point), POWERS, INTEGER_POWERS, slots, out)
        if rows < 0:
            return None
        parts.append(out[:, :rows])
    return parts


def parse_block(data: bytes, end: int, keep: list[bool], delimiter: str, point: str,
                threads: int) -> list[np.ndarray] | None:
    """The numbers of the kept columns of the lines data[:end] as arrays [kept column, row], in order, the text cut
    at line ends into a part per thread; None when any line is not len(keep) plain numbers. `data` has PADDING bytes
    after `end`. Call only when `available()`."""
    if len(data) < end + PADDING or end == 0 or data[end - 1] != NEWLINE:
        raise ValueError("a block must end in a line feed and have PADDING bytes after it")
    if delimiter == point or delimiter in "-\n0123456789" or point in "-\n0123456789":
        return None  # a cell's own characters cannot also separate cells
    text = np.frombuffer(data, np.uint8)
    cuts = [0]
    for part in range(1, max(threads, 1)):
        cut = data.find(b"\n", max(end * part // threads, cuts[-1]), end) + 1
        if 0 < cut < end:
            cuts.append(cut)
    cuts.append(end)
    results: list = [None] * (len(cuts) - 1)

    def parse(part: int) -> None:
        try:
            results[part] = parse_lines(text, cuts[part], cuts[part + 1], keep, delimiter, point)
        except Exception:  # the part declines: pyarrow reads the block next and says what it finds
            results[part] = None

    helpers = [threading.Thread(target=parse, args=(part,)) for part in range(1, len(results))]
    for helper in helpers:
        helper.start()
    parse(0)
    for helper in helpers:
        helper.join()
    return None if any(result is None for result in results) else [array for arrays in results for array in arrays]
