"""A run given twice is no held-out evidence: a fold that predicts a run by a fit on its own copy is judged on
rows it was fitted on. Two runs are refused as one recording when they share a stretch of calls — the same
values of the columns the model reads, in the same order — whatever else differs: the file's format (CSV,
Parquet, .npz), its bytes (line endings, quoting, number spellings, float32 storage), its column order, a
column the model does not read, its time stamps, a row dropped, or the run cut into two files.

A stretch counts only when it moves (at least a third of its calls differ from the call before), so runs that
stand still at the same quantised readings are not taken for copies. Real runs of a machine never repeat
WINDOW moving calls to the bit; a copy always does."""
from __future__ import annotations

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.recordings.table import Table

WINDOW = 30  # calls in a stretch that, repeated to the bit in another run, makes it a copy
MIXER = np.uint64(0x9E3779B97F4A7C15)  # a 64-bit odd constant (golden ratio): spreads each value over the hash


def refuse_copies(tables: list[Table], why: str, columns: tuple[str, ...] | None = None) -> None:
    """Refuse a run that is another's copy, or holds a stretch of it, naming both files; `why` says what the copy
    would spoil. `columns`: the columns the model reads (default: all but none; every table must have them)."""
    seen: dict[str, str] = {}
    for table in tables:
        if table.content_sha256 in seen:
            first = seen[table.content_sha256]
            same = "its very bytes" if table.sha256 == _bytes_of(tables, first) else \
                "the same columns and numbers in other bytes"
            raise UserError(f"{table.path}: the same recording as {first} ({same}); {why}; give each run once")
        seen[table.content_sha256] = table.path
    _refuse_shared_stretches(tables, why, columns)


def _bytes_of(tables: list[Table], path: str) -> str:
    return next(t.sha256 for t in tables if t.path == path)


def _refuse_shared_stretches(tables: list[Table], why: str, columns: tuple[str, ...] | None) -> None:
    if len(tables) < 2:
        return
    names = [c for c in (columns or sorted(tables[0].columns)) if all(c in t.columns for t in tables)]
    if not names:
        return
    window = min(WINDOW, min(t.rows for t in tables))
    hashes, owners, starts = [], [], []
    for k, table in enumerate(tables):
        found, at = _moving_windows(table, names, window)
        hashes.append(found)
        owners.append(np.full(len(found), k))
        starts.append(at)
    hashes, owners, starts = np.concatenate(hashes), np.concatenate(owners), np.concatenate(starts)
    order = np.lexsort((owners, hashes))
    same = (hashes[order][1:] == hashes[order][:-1]) & (owners[order][1:] != owners[order][:-1])
    if not same.any():
        return
    pairs = [(order[j], order[j + 1]) for j in np.flatnonzero(same)]
    a, b = min(((x, y) if owners[x] < owners[y] else (y, x) for x, y in pairs),
               key=lambda pair: (owners[pair[1]], starts[pair[1]]))  # the first run that repeats, where it begins
    first, second = tables[owners[a]], tables[owners[b]]
    raise UserError(f"{second.path}: calls {starts[b] + 1}..{starts[b] + window} hold the same values of "
                    f"{', '.join(names)}, in the same order, as calls {starts[a] + 1}..{starts[a] + window} of "
                    f"{first.path} (a copy of one recording, in part or with other bytes); {why}; give each run once")


def _moving_windows(table: Table, names: list[str], window: int) -> tuple[np.ndarray, np.ndarray]:
    """The hash of every stretch of `window` calls that moves, and where each starts. Values are compared as the
    block reads them (binary32), NaN and -0.0 one way."""
    values = np.column_stack([np.asarray(table.columns[c], np.float64) for c in names]).astype(np.float32) + 0.0
    values = np.where(np.isnan(values), np.float32(np.nan), values).astype(np.float32)
    rows = np.zeros(len(values), np.uint64)
    with np.errstate(over="ignore"):
        for bits in values.view(np.uint32).T.astype(np.uint64):  # one 64-bit hash per call, wrapping
            rows = (rows ^ bits) * MIXER
            rows ^= rows >> np.uint64(29)
        count = len(rows) - window + 1
        if count < 1:
            return np.empty(0, np.uint64), np.empty(0, int)
        stretch = np.zeros(count, np.uint64)
        for k in range(window):
            stretch = (stretch * MIXER) ^ rows[k:k + count]
    changes = np.r_[0, np.cumsum(rows[1:] != rows[:-1])]
    moving = (changes[window - 1:] - changes[:count]) >= window // 3
    return stretch[moving], np.flatnonzero(moving)
