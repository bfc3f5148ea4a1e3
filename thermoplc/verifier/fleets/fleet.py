"""verify --manifest: many (block, data, model) pairs, checked in parallel processes (fleets).

The manifest is a CSV with a header naming at least `block` and `data`, and per row either a
`model` (compare with its float32 reference) or an `expect` (OUTPUT=COLUMN[;...] of a recorded
PLC trace); an optional `inputs` column maps block inputs to columns (NAME=COLUMN[;...]).
Relative paths are taken from the manifest's folder. Results come back in manifest order.
"""
from __future__ import annotations

import csv
import signal
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from thermoplc.base.errors import UserError, unreadable
from thermoplc.base.locations import is_url
from thermoplc.base.values import Every
from thermoplc.verifier.fleets.pair import Outcome, Pair, verify_pair


def _mapping(text: str, manifest: str, line: int, field: str) -> dict | None:
    if not text.strip():
        return None
    mapping = {}
    for item in text.split(";"):
        name, sep, column = item.partition("=")
        if not sep or not name.strip() or not column.strip():
            raise UserError(f"{manifest}:{line}: column {field!r}: expected NAME=COLUMN[;NAME=COLUMN...], found {item!r}")
        mapping[name.strip()] = column.strip()
    return mapping


def read_manifest(path: str, reading: tuple = (), probe_every: int | Every | None = None,
                  resample_s: float | None = None) -> list[Pair]:
    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError) as exc:
        raise unreadable(path, exc, "the manifest") from None
    if not rows:
        raise UserError(f"{path}: the manifest is empty; expected a header with block,data,model")
    header = [h.strip().lower() for h in rows[0]]
    for needed in ("block", "data"):
        if needed not in header:
            raise UserError(f"{path}:1: the header has no {needed!r} column; expected block,data and model or expect")
    base = Path(path).resolve().parent
    pairs = []
    for line, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        if len(row) != len(header):
            raise UserError(f"{path}:{line}: {len(row)} fields, expected {len(header)} as in the header")
        cell = dict(zip(header, (c.strip() for c in row)))
        for field in ("block", "data", "model"):
            if "\0" in cell.get(field, ""):
                raise UserError(f"{path}:{line}: column {field!r}: a NUL character in {cell[field]!r}; no file is named so")
        model, expect = cell.get("model", ""), cell.get("expect", "")
        if bool(model) == bool(expect):
            raise UserError(f"{path}:{line}: give either a model or an expect column value, not {'both' if model else 'neither'}")
        where = lambda p: str(base / p) if p and not Path(p).is_absolute() and not is_url(p) else p
        pairs.append(Pair(line, where(cell["block"]), where(cell["data"]), where(model) or None,
                          _mapping(expect, path, line, "expect"), _mapping(cell.get("inputs", ""), path, line, "inputs"),
                          reading=reading, probe_every=probe_every, resample_s=resample_s))
    if not pairs:
        raise UserError(f"{path}: the manifest lists no pairs")
    return pairs


def verify_fleet(pairs: list[Pair], jobs: int, engine: str, scheduler: str | None = None
                 ) -> tuple[list[Outcome], float]:
    """Outcomes in manifest order, and the wall time of the whole fleet: in this process, in `jobs` processes,
    or as tasks of the Dask cluster at `scheduler` (verifier/fleets/fleet_dask.py)."""
    if scheduler:
        from thermoplc.verifier.fleets.fleet_dask import verify_on_cluster
        return verify_on_cluster(pairs, engine, scheduler)
    started = time.perf_counter()
    if jobs <= 1:
        outcomes = [verify_pair(p, engine) for p in pairs]
        return outcomes, time.perf_counter() - started
    pool = ProcessPoolExecutor(max_workers=min(jobs, len(pairs)), initializer=_leave_signals_to_the_parent)
    try:
        outcomes = list(pool.map(verify_pair, pairs, [engine] * len(pairs)))
    except BaseException:  # Ctrl-C, SIGTERM: stop the workers now, not after the pairs they are on
        for worker in list(getattr(pool, "_processes", {}).values()):
            worker.kill()  # they ignore SIGTERM (the parent decides)
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
    return outcomes, time.perf_counter() - started


def _leave_signals_to_the_parent() -> None:
    """A worker ignores SIGINT and SIGTERM: the parent decides, and ends the workers itself."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


def format_fleet(outcomes: list[Outcome], manifest: str, seconds: float | None = None) -> str:
    lines = [f"{'line':>5}  {'status':<14}{'block':<28}{'data':<28}detail"]
    for o in outcomes:
        lines.append(f"{o.pair.line:>5}  {o.status:<14}{Path(o.pair.block).name:<28}{Path(o.pair.data).name:<28}{o.detail}")
    counts = {s: sum(o.status == s for o in outcomes) for s in ("bit-exact", "NOT bit-exact", "error")}
    lines.append(f"{manifest}: {len(outcomes)} pairs: " + ", ".join(f"{n} {s}" for s, n in counts.items()))
    if seconds is not None:
        cycles = sum(o.cycles for o in outcomes)
        rate = cycles / seconds if seconds > 0 else float("inf")
        lines.append(f"throughput: {cycles:,} calls verified in {seconds:.1f} s, {rate:,.0f} calls/s "
                     f"({seconds / max(len(outcomes), 1):.2f} s per pair)")
    return "\n".join(lines)


def fleet_document(outcomes: list[Outcome], manifest: str) -> dict:
    """The `--json` document of a fleet (schema verify_fleet_v1.json): no timings, so the same manifest gives
    the same bytes wherever its pairs ran."""
    counts = {s: sum(o.status == s for o in outcomes) for s in ("bit-exact", "NOT bit-exact", "error")}
    return {"format": "thermoplc-verify-fleet", "version": 1, "ok": counts["bit-exact"] == len(outcomes),
            "manifest": manifest,
            "pairs": [{"line": o.pair.line, "block": o.pair.block, "data": o.pair.data, "model": o.pair.model,
                       "expect": o.pair.expect, "status": o.status, "detail": o.detail, "cycles": o.cycles}
                      for o in outcomes],
            "counts": counts}
