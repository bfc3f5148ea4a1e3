"""The ST dialects thermoplc writes, found in the modules of this package that declare one (`DIALECT =
DialectDefinition(...)`, definition.py): the single list `generate --dialect` offers, the printer spells, the test
bench sizes its data by and a block file is recognised by. Adding a dialect is a module here and its template
(templates/); docs/architecture.md lists the steps."""
from __future__ import annotations

import functools
import importlib
import pkgutil

from thermoplc.generator.dialects.definition import BenchSpelling, DialectDefinition, Target

__all__ = ["BenchSpelling", "DialectDefinition", "Target", "named_where", "plcopen_wrapped", "recognized", "registry"]


@functools.cache
def registry() -> dict[str, DialectDefinition]:
    """Dialect name -> record, by rank."""
    found = []
    for module in pkgutil.iter_modules(__path__):
        record = getattr(importlib.import_module(f"{__name__}.{module.name}"), "DIALECT", None)
        if isinstance(record, DialectDefinition):
            found.append(record)
    found.sort(key=lambda record: record.rank)
    if len({r.name for r in found}) != len(found) or len({r.rank for r in found}) != len(found):
        raise RuntimeError(f"two dialects share a name or a rank: {[(r.rank, r.name) for r in found]}")
    if [r.recognized_by is None for r in found] != [False] * (len(found) - 1) + [True]:
        raise RuntimeError("one dialect, ranked last, recognizes the blocks no other does (recognized_by=None): "
                           f"{[(r.rank, r.name, r.recognized_by) for r in found]}")
    if sum(r.plcopen for r in found) != 1:
        raise RuntimeError(f"one dialect is the one PLCopen XML wraps: {[r.name for r in found if r.plcopen]}")
    return {record.name: record for record in found}


def named_where(holds) -> str:
    """The names of the dialects whose record `holds` is true of, as a help lists them: 'tia, iec'."""
    return ", ".join(name for name, record in registry().items() if holds(record))


def plcopen_wrapped() -> DialectDefinition:
    """The dialect PLCopen XML wraps (the one record with `plcopen`; the registry refuses any other count)."""
    return next(record for record in registry().values() if record.plcopen)


def recognized(text: str) -> str:
    """The dialect a block source generate wrote is in: the first by rank that recognizes it."""
    return next(name for name, record in registry().items() if record.recognizes(text))
