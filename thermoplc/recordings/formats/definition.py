"""The record of one column file format recordings are read from (`FORMAT = InputFormat(...)`).

CSV, the text format, is not a record: `recordings/table.py` and `recordings/chunks.py` read it with the reading
options (decimal comma, date-times, units rows), and a file whose ending no record claims is read as CSV. A record
reads numbers that are columns already; the table built from them (the time column, the gap rule, the digest)
is the same for every format."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator


class CannotStream(Exception):
    """The fast reader declines this file (the careful reader decides, and words any error)."""


@dataclass(frozen=True)
class InputFormat:
    name: str
    suffix: str  # the ending of a file's name that picks it, lower case (a URL's query aside)
    title: str  # how the help names it: ".npz", "Parquet"
    rank: int  # its place in the lists the help and a folder's runs show
    # (path, sparse columns, gaps allowed) -> column name -> float64 values, at least one column of at least one row,
    # every cell a finite number but NaN in a sparse column or where gaps are allowed; any other file is refused
    # (UserError) naming the file, column and row
    columns: Callable[[str, frozenset, bool], dict]
    # (path, rows per chunk) -> the file's columns, chunk by chunk, not yet checked; raises CannotStream to leave
    # the file to `columns` (which words the error)
    chunks: Callable[[str, int], Iterator[dict]]
