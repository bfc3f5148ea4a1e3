"""verify --model on a long recording in bounded memory, at disk speed (issue 17).

The file is read chunk by chunk (recordings/chunks.py::stream_columns), the float32 and float64
references are computed chunk by chunk by the compiled model loops (models/streaming.py, which
never see the ST), the block runs chunk by chunk on the fast engine (its own ST -> C
translation, state kept between chunks) and every output is compared bit for bit as it comes.

This route only ever says "bit-exact". Whenever anything is not plain -- the file needs the
careful reader, the data are sampled at another period, the block and the model disagree on an
output, the fast engine meets a NaN/Inf/subnormal, an output is not finite -- it gives up and
the caller runs the whole-recording path (read_table + verify_against_model), which words every
error and every mismatch exactly as before. So the streaming route changes how fast a good
recording is proven, never what is reported.
"""
from __future__ import annotations

import time
from collections import Counter
from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.base.locations import size
from thermoplc.contract.outputs import CONTROL_INPUT_START, block_names, named
from thermoplc.fitting.fit import SAMPLING_TOLERANCE
from thermoplc.models.model import Model
from thermoplc.models.streaming import StreamingReference, streamable
from thermoplc.recordings.chunks import CannotStream, stream_columns
from thermoplc.recordings.reading import Reading
from thermoplc.verifier.engines.contraction import MAX_CALLS, ContractionRun
from thermoplc.verifier.replays.expectation import check_interface, mistyped
from thermoplc.verifier.replays.mapping import known_overrides
from thermoplc.verifier.replays.replay import (Report, compare_constants, load_block, block_limits, subnormal_declarations,
                                       unsafe_findings, verify_against_model)
from thermoplc.verifier.replays.recording import read_recording
from thermoplc.verifier.engines.typed import differing_rows, first_non_finite

MAX_DISTINCT_STEPS = 1 << 20  # distinct time steps kept for the median; beyond: the whole-recording path
# a file this small is read whole: its reference by the numpy loops takes less than loading numba (models/kernels.py)
# and its memory is no concern (compressed npz or Parquet expand tenfold at most: about 40 MiB)
WHOLE_BELOW_BYTES = 4 << 20


class Streamed(NamedTuple):
    """What the streamed route made of a recording: the report when it decides (None: read the recording whole),
    the route taken ("streamed", or "whole recording (why)") and the seconds of each stage (benchmarks/large.py)."""
    report: Report | None
    route: str
    seconds: dict


class _GiveUp(Exception):
    """The streaming route does not decide this case."""


def verify_streaming(block: str, model: Model, model_path: str, data: str, overrides: dict | None = None,
                     engine: str = "auto", reading: Reading | None = None, progress=None) -> Streamed:
    """The report when the streamed recording proves the block bit-exact, with its route and stage times; no
    report when the streaming route does not decide (the caller then runs read_table + verify_against_model
    itself, at the call depth it always had, so every message -- even a RecursionError's -- stays as it was)."""
    started = time.perf_counter()
    if str(data) == "-":  # standard input on every path, never a file named '-' (read whole: one pass only)
        return Streamed(None, "whole recording (standard input)", {})
    if model.probe is not None:  # the probings are derived from the whole target (verifier/replays/probings.py)
        return Streamed(None, "whole recording (probe fusion)", {})
    if model.resample is not None:  # raw data taken onto the cycle (verifier/replays/recording.py) are read whole
        return Streamed(None, "whole recording (resampled)", {})
    reading = model.reading if reading is None else reading
    if reading.time_format != "auto":  # Excel serial days are numbers the streamed route would take as seconds
        return Streamed(None, "whole recording (--time-format)", {})
    try:
        report, seconds = _verify_streaming(block, model, model_path, str(data), overrides, engine, reading.decimal,
                                            progress)
    except (_GiveUp, CannotStream, UserError, RecursionError, MemoryError) as exc:
        return Streamed(None, f"whole recording ({type(exc).__name__}: {str(exc)[:200]})",
                        {"streaming attempt": time.perf_counter() - started})
    return Streamed(report, "streamed", seconds)


def verify_file_against_model(block: str, model: Model, model_path: str, data: str, overrides: dict | None = None,
                              engine: str = "auto", reading: Reading | None = None, progress=None) -> Streamed:
    """verify_against_model on the file `data`: streamed when it can be, else read whole (its report, the
    route's reason and the whole path's two stages)."""
    streamed = verify_streaming(block, model, model_path, data, overrides, engine, reading, progress)
    if streamed.report is not None:
        return streamed
    t = time.perf_counter()
    table = read_recording(data, model, progress, reading, overrides=overrides, model_path=model_path)
    read_s = time.perf_counter() - t
    t = time.perf_counter()
    report = verify_against_model(block, model, model_path, table, overrides, engine)
    return Streamed(report, streamed.route, {**streamed.seconds, "read": read_s,
                                             "reference + replay + compare": time.perf_counter() - t})


class _Steps:
    """Time steps of the whole recording, kept as distinct values with counts: the exact median
    and the first step off it, as fitting/fit.py::sample_period computes them."""

    def __init__(self):
        self.counts = Counter()
        self.last = None
        self.rows = 0

    def add(self, t: np.ndarray) -> None:
        if self.last is not None:
            t = np.concatenate([[self.last], t])
        steps = np.diff(t)
        if (steps <= 0).any():
            raise _GiveUp("time does not increase")
        values, counts = np.unique(steps, return_counts=True)
        self.counts.update(dict(zip(values.tolist(), counts.tolist())))
        if len(self.counts) > MAX_DISTINCT_STEPS:
            raise _GiveUp("too many distinct time steps")
        self.last = t[-1]

    def median(self) -> float:
        values = sorted(self.counts)
        ends = np.cumsum([self.counts[v] for v in values])
        n = int(ends[-1])

        def at(i):
            return values[int(np.searchsorted(ends, i, side="right"))]
        if n % 2:
            return float(at(n // 2))
        return float(np.mean([at(n // 2 - 1), at(n // 2)]))

    def check(self, period: float) -> None:
        if not self.counts:
            return  # fewer than two rows: verify_against_model does not check the period either
        dt = self.median()
        if any(abs(s - dt) > SAMPLING_TOLERANCE * dt for s in self.counts):
            raise _GiveUp("a time step off the sampling period")
        if abs(dt - period) > SAMPLING_TOLERANCE * period:
            raise _GiveUp("sampled at another period")


def _verify_streaming(block: str, model: Model, model_path: str, data: str, overrides, engine: str, decimal: str,
                      progress) -> tuple[Report, dict]:
    timings = {"setup": 0.0, "read": 0.0, "reference": 0.0, "replay": 0.0, "compare": 0.0}
    t = time.perf_counter()
    if engine == "interp" or not streamable(model):
        raise _GiveUp(f"no streaming for {model.kind} models or engine {engine}")
    try:
        short = size(data) < WHOLE_BELOW_BYTES
    except OSError:  # missing or unreadable: the whole-recording path says so in its words
        raise _GiveUp("cannot stat the recording") from None
    if short:
        raise _GiveUp("a short recording (read whole)")
    program, replayer = load_block(block, engine)
    if replayer.native is None:
        raise _GiveUp("no fast engine")
    if subnormal_declarations(program.decls, block):
        raise _GiveUp("a subnormal declared value (the whole-recording path reports it)")
    limits = block_limits(program, block)
    mapping = known_overrides(overrides, [s.name for s in model.inputs], model_path)
    column_of = {s.name: mapping.get(s.name, s.column) for s in model.inputs}
    names = list(dict.fromkeys([model.time_column, *column_of.values()]))
    controls = tuple(c for c in CONTROL_INPUT_START if c not in names)  # columns that would drive Enable or Reset
    check_interface(replayer.machine, block, column_of, f"the inputs of {Path(model_path).name}")
    ref32, ref64 = StreamingReference(model, limits, "f32"), StreamingReference(model, limits, "f64")
    output_names = block_names(model, [d.name for d in replayer.machine.outputs])
    types, steps, rows, quantisation = None, _Steps(), 0, 0.0
    target = model.target.name
    replayer.native.reset()
    fused = ContractionRun(program, block, MAX_CALLS)
    timings["setup"] = time.perf_counter() - t
    chunks = iter(stream_columns(data, names, decimal, optional=controls))
    while True:
        t = time.perf_counter()
        chunk = next(chunks, None)
        timings["read"] += time.perf_counter() - t
        if chunk is None:
            break
        t = time.perf_counter()
        steps.add(chunk.columns[model.time_column])
        inputs = _chunk_inputs(chunk, column_of, controls)
        timings["read"] += time.perf_counter() - t
        t = time.perf_counter()
        expected = named(ref32.step(inputs), output_names)
        ideal = ref64.step(inputs)
        timings["reference"] += time.perf_counter() - t
        if types is None:
            types = _output_types(replayer, block, model_path, expected)
        t = time.perf_counter()
        result = replayer.native.run(inputs, chunk.rows)
        timings["replay"] += time.perf_counter() - t
        if result is None or result[1]:
            raise _GiveUp("the fast engine met a value the interpreter reports")
        t = time.perf_counter()
        quantisation = max(quantisation, _compare_chunk(result[0], expected, types, ideal[target], target))
        fused.feed(inputs, expected, chunk.rows)
        rows += chunk.rows
        timings["compare"] += time.perf_counter() - t
        if progress is not None:
            progress(f"verified {rows:,} rows of {Path(data).name}")
    if rows == 0 or types is None:
        raise _GiveUp("no rows")
    if rows >= 2:
        steps.check(model.sample_period_s)
    t = time.perf_counter()
    findings = tuple(replace(f) for f in replayer.machine.findings.values())
    if unsafe_findings(findings, True):
        raise _GiveUp("unsafe findings")
    against = f"the float32 reference of {Path(model_path).name} ({model.kind})"
    report = Report(block, against, Path(data).name, rows, tuple(types), None, findings, timings["replay"],
                    {target: quantisation}, engine="fast", engine_note=replayer.note)
    checked, errors = compare_constants(program, model, limits)
    timings["compare"] += time.perf_counter() - t
    contraction = replace(fused.result(), rows=rows)
    return (replace(report, constants_checked=checked, constant_errors=errors, limits=limits, contraction=contraction),
            {**timings, "rows": rows})


def _chunk_inputs(chunk, column_of: dict, controls: tuple) -> dict:
    """The model inputs of one chunk as float32; gives up where only the whole-recording path is right:
    the data drive Enable or Reset (the streamed reference is the always-enabled, never-reset block),
    or a cell is beyond the largest REAL."""
    for name in controls:
        if name in chunk.columns and (chunk.columns[name] != CONTROL_INPUT_START[name]).any():
            raise _GiveUp(f"the data drive {name}")
    inputs = {}
    for name, column in column_of.items():
        with np.errstate(over="ignore"):
            inputs[name] = chunk.columns[column].astype(np.float32)
        if np.isinf(inputs[name]).any():
            raise _GiveUp("a cell beyond the largest REAL")
    return inputs


def _compare_chunk(produced: dict, expected: dict, types: dict, ideal, target: str) -> float:
    """The chunk's quantisation error of the target (0 for no rows); gives up on any differing bit or
    non-finite REAL output, which the whole-recording path then reports with its row."""
    for name, want in expected.items():
        if len(differing_rows(types[name], produced[name], want)):
            raise _GiveUp("a mismatch (the whole-recording path reports it)")
        if types[name] == "REAL" and first_non_finite(produced[name]) is not None:
            raise _GiveUp("an output is not finite")
    if not len(expected[target]):
        return 0.0
    gap = float(np.max(np.abs(expected[target].astype(np.float64) - ideal)))
    if not np.isfinite(gap):
        raise _GiveUp("the quantisation error is not finite")
    return gap


def _output_types(replayer, block: str, model_path: str, expected: dict) -> dict:
    """The checks verify_against_model makes on the block's outputs; any failure: the whole path words it."""
    machine = replayer.machine
    declared = [d.name for d in machine.outputs]
    if sorted(declared) != sorted(expected):
        raise _GiveUp("outputs differ")
    if mistyped(machine, expected):
        raise _GiveUp("an output or input of another type")
    by_name = {d.name: d.type.base for d in machine.outputs}
    return {name: by_name[name] for name in expected}
