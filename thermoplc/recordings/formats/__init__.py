"""The column file formats recordings are read from, found in the modules of this package that declare one
(`FORMAT = InputFormat(...)`, see `definition.py`): the single list `read_table`, the streamed reading, a folder's
runs and the help's words read. Adding a format is a new module here (and its rows in tests/bad_inputs.py)."""
from __future__ import annotations

import functools
import importlib
import pkgutil

from thermoplc.base.locations import name as location_name
from thermoplc.recordings.formats.definition import CannotStream, InputFormat

__all__ = ["CannotStream", "InputFormat", "described", "format_of", "registry", "suffixes"]
TEXT_SUFFIX = ".csv"


@functools.cache
def registry() -> dict[str, InputFormat]:
    """Format name -> record, by rank."""
    found = []
    for module in pkgutil.iter_modules(__path__):
        record = getattr(importlib.import_module(f"{__name__}.{module.name}"), "FORMAT", None)
        if isinstance(record, InputFormat):
            found.append(record)
    found.sort(key=lambda record: record.rank)
    if len({r.name for r in found}) != len(found) or len({r.rank for r in found}) != len(found):
        raise RuntimeError(f"two input formats share a name or a rank: {[(r.rank, r.name) for r in found]}")
    endings = [TEXT_SUFFIX, *(r.suffix for r in found)]
    for ending in endings[1:]:
        if not ending.startswith(".") or ending != ending.lower():
            raise RuntimeError(f"input format ending {ending!r}: expected a '.' first and lower case")
    clashes = [(a, b) for i, a in enumerate(endings) for j, b in enumerate(endings) if i != j and a.endswith(b)]
    if clashes:  # a file's name would be claimed by two: 'run.csv.gz' ends in '.gz' too
        raise RuntimeError(f"input format endings that end alike: {clashes}")
    return {record.name: record for record in found}


def format_of(path) -> InputFormat | None:
    """The format a file's name ends in, or None: CSV (any other ending is read as CSV text)."""
    lower = location_name(str(path)).lower()  # a URL's query is no part of its name
    return next((record for record in registry().values() if lower.endswith(record.suffix)), None)


def suffixes() -> tuple[str, ...]:
    """The endings a folder's runs are taken by: CSV's and each format's."""
    return (TEXT_SUFFIX, *(record.suffix for record in registry().values()))


def described() -> str:
    """The formats as the help names them: 'CSV, .npz or Parquet'."""
    names = ["CSV", *(record.title for record in registry().values())]
    return ", ".join(names[:-1]) + f" or {names[-1]}" if len(names) > 1 else names[0]
