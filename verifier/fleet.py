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
from dataclasses import dataclass
from pathlib import Path

from thermoplc.base.errors import UserError, unreadable
from thermoplc.base.locations import is_url


@dataclass(frozen=True)
class Pair:
    line: int
    block: str
    data: str
    model: str | None
    expect: dict | None
    inputs: dict | None
    sha256: tuple[tuple[str, str], ...] = ()  # (file, digest) of each file a task run elsewhere must find
    decimal: str = "auto"  # the data's decimal separator (--decimal)
    probe_every: int | None = None  # a fused block on a full-rate target: a probing every N calls (--probe-every)
    resample_s: float | None = None  # raw data taken onto the block's cycle (--resample; a model's own rule applies anyway)


@dataclass(frozen=True)
class Outcome:
    pair: Pair
    status: str  # 'bit-exact', 'NOT bit-exact', 'error'
    detail: str  # one line: cycles and rate, or the error message
    text: str  # the full report
    cycles: int = 0  # calls replayed and compared
    seconds: float = 0.0  # wall time of this pair (reading, reference, replay, compare)


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


def read_manifest(path: str, decimal: str = "auto", probe_every: int | None = None,
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
                          decimal=decimal, probe_every=probe_every, resample_s=resample_s))
    if not pairs:
        raise UserError(f"{path}: the manifest lists no pairs")
    return pairs


def verify_pair(pair: Pair, engine: str) -> Outcome:
    """One pair, in a worker process; errors become an outcome, never an exception."""
    started = time.perf_counter()
    from thermoplc.models.modelfile import load_model
    from thermoplc.recordings.table import read_table
    from thermoplc.verifier.replay import verify_against_model, verify_against_trace
    from thermoplc.verifier.recording import read_recording, resampling_for
    from thermoplc.verifier.stream import verify_streaming
    try:
        _same_bytes(pair)
        if pair.model:
            model = load_model(pair.model)
            report = (verify_streaming(pair.block, model, pair.model, pair.data, pair.inputs, engine, pair.decimal)
                      if resampling_for(model, pair.resample_s) is None else None)
            if report is None:
                table = read_recording(pair.data, model, decimal=pair.decimal, period_s=pair.resample_s,
                                       overrides=pair.inputs)
                report = verify_against_model(pair.block, model, pair.model, table, pair.inputs, engine,
                                              pair.probe_every)
        else:
            if pair.resample_s is not None:
                raise UserError("--resample takes raw data onto a model's cycle; a pair compared with a PLC trace "
                                "(expect) is on the block's cycle already")
            table = read_table(pair.data, decimal=pair.decimal)
            report = verify_against_trace(pair.block, table, pair.expect, pair.inputs, engine=engine)
    except UserError as exc:
        return Outcome(pair, "error", str(exc), str(exc), 0, time.perf_counter() - started)
    status = "bit-exact" if report.ok else "NOT bit-exact"
    detail = f"{report.cycles} cycles, {report.engine}"
    if report.mismatch is not None:
        detail += f", first divergent cycle {report.mismatch.cycle} ({report.mismatch.output})"
    if report.failure is not None:
        detail += f", run-time error: {report.failure}"
    return Outcome(pair, status, detail, report.text(), report.cycles, time.perf_counter() - started)


def _same_bytes(pair: Pair) -> None:
    """Refuse a pair whose files here hold other bytes than where the command was given them: a worker that
    resolves a path in its own folder, or another machine's copy, must fail the pair, never pass it."""
    from thermoplc.recordings.table import sha256_of
    for path, digest in pair.sha256:
        try:
            found = sha256_of(path)
        except OSError as exc:
            raise UserError(f"{path}: cannot read it where this pair ran: {exc.strerror or exc}") from None
        if found != digest:
            raise UserError(f"{path}: other bytes where this pair ran (sha256 {found[:12]}...) than where the command "
                            f"was given them ({digest[:12]}...); every worker must read the same files")


def verify_fleet(pairs: list[Pair], jobs: int, engine: str, scheduler: str | None = None
                 ) -> tuple[list[Outcome], float]:
    """Outcomes in manifest order, and the wall time of the whole fleet: in this process, in `jobs` processes,
    or as tasks of the Dask cluster at `scheduler` (verifier/fleet_dask.py)."""
    if scheduler:
        from thermoplc.verifier.fleet_dask import verify_on_cluster
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
