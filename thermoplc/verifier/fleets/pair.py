"""One pair of a fleet (block, data, and a model or a PLC trace) and its outcome, verified where it runs:
in this process, a worker process of --jobs, or a Dask worker (verifier/fleets/fleet_dask.py)."""
from __future__ import annotations

import time
from dataclasses import dataclass

from thermoplc.base.errors import UserError
from thermoplc.base.values import Every


@dataclass(frozen=True)
class Pair:
    line: int
    block: str
    data: str
    model: str | None
    expect: dict | None
    inputs: dict | None
    sha256: tuple[tuple[str, str], ...] = ()  # (file, digest) of each file a task run elsewhere must find
    reading: tuple = ()  # (option, value) of --decimal, --gaps, --time-format as given (recordings/reading.py::resolved)
    probe_every: int | Every | None = None  # a fused block on a full-rate target: a probing every N calls or a duration
    resample_s: float | None = None  # raw data taken onto the block's cycle (--resample; a model's own rule applies anyway)


@dataclass(frozen=True)
class Outcome:
    pair: Pair
    status: str  # 'bit-exact', 'NOT bit-exact', 'error'
    detail: str  # one line: cycles and rate, or the error message
    text: str  # the full report
    cycles: int = 0  # calls replayed and compared
    seconds: float = 0.0  # wall time of this pair (reading, reference, replay, compare)


def verify_pair(pair: Pair, engine: str) -> Outcome:
    """One pair, in a worker process; errors become an outcome, never an exception."""
    started = time.perf_counter()
    from thermoplc.models.modelfile import load_model
    from thermoplc.recordings.reading import resolved
    from thermoplc.recordings.table import read_table
    from thermoplc.verifier.replays.replay import verify_against_model, verify_against_trace
    from thermoplc.verifier.replays.recording import read_recording, resampling_for
    from thermoplc.verifier.replays.stream import verify_streaming
    try:
        _same_bytes(pair)
        if pair.model:
            model = load_model(pair.model)
            reading = resolved(dict(pair.reading), model.reading)
            report = (verify_streaming(pair.block, model, pair.model, pair.data, pair.inputs, engine, reading).report
                      if resampling_for(model, pair.resample_s) is None else None)
            if report is None:
                table = read_recording(pair.data, model, reading=reading, period_s=pair.resample_s,
                                       overrides=pair.inputs, model_path=pair.model)
                report = verify_against_model(pair.block, model, pair.model, table, pair.inputs, engine,
                                              pair.probe_every)
        else:
            if pair.resample_s is not None:
                raise UserError("--resample takes raw data onto a model's cycle; a pair compared with a PLC trace "
                                "(expect) is on the block's cycle already")
            table = read_table(pair.data, reading=resolved(dict(pair.reading)))
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
