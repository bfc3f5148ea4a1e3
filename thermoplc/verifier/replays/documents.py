"""The verifier's reports as JSON documents (`verify --json`, `diff --json`), for CI pipelines.

Each document names its format and version; the schemas that describe them ship in the package
(`thermoplc/schemas/*.json`, docs/json.md). Values a PLC holds are given exactly: a REAL as its
binary32 bits beside the shortest decimal that rounds to them (non-finite values as text), so a
consumer never compares rounded decimals. Timings are left out: the same inputs give the same
document, byte for byte."""
from __future__ import annotations

import math

import numpy as np

from thermoplc.base.binary32 import f32_hex
from thermoplc.verifier.replays.diff import BlockDiff
from thermoplc.verifier.replays.faults import FaultReport
from thermoplc.verifier.engines.semantics import Finding
from thermoplc.verifier.replays.replay import Report

VERSION = 1


def value(v) -> dict:
    """A block or reference value: {"type", "value", "bits"} (bits for REAL only)."""
    if isinstance(v, bool) or isinstance(v, np.bool_):
        return {"type": "BOOL", "value": bool(v)}
    if isinstance(v, (int, np.integer)):
        return {"type": "INT", "value": int(v)}
    if isinstance(v, (float, np.floating)):
        x = float(np.float32(v))
        return {"type": "REAL", "value": float(str(np.float32(x))) if math.isfinite(x) else str(np.float32(x)),
                "bits": f32_hex(x)}
    if isinstance(v, list):
        return {"type": "ARRAY", "value": [value(item) for item in v]}
    return {"type": "other", "value": None if v is None else repr(v)}


def _findings(findings: tuple[Finding, ...]) -> list[dict]:
    return [{"kind": f.kind, "line": f.pos[0], "column": f.pos[1], "detail": f.detail, "count": f.count,
             "first_cycle": f.first_cycle} for f in findings]


def verify_document(report: Report) -> dict:
    """The `verify --json` document (the block against a model or a recorded trace): verdict, first mismatch
    with its REALs as exact bits, the constants check, and what made the block unsafe."""
    m = report.mismatch
    return {
        "format": "thermoplc-verify", "version": VERSION, "ok": report.ok,
        "block": report.block, "against": report.against, "data": report.data,
        "cycles": report.cycles, "outputs": list(report.outputs),
        "first_mismatch": None if m is None else {
            "cycle": m.cycle, "data_line": m.row_line, "time_s": m.time, "output": m.output,
            "block": value(m.block_value), "expected": value(m.expected_value),
            "variables": {name: value(v) for name, v in m.variables.items()}},
        "runtime_error": report.failure,
        "constants": {"checked": report.constants_checked, "differ": list(report.constant_errors)},
        "unsafe": list(report.unsafe),
        "findings": _findings(report.findings),
        "float32_vs_float64_um": dict(report.quantisation_um),
        "contraction": None if report.contraction is None else {
            "max_deviation": {k: value(v) for k, v in report.contraction.deviation.items()},
            "calls": report.contraction.calls, "failure": report.contraction.failure or None},
        "engine": report.engine,
        "note": report.control,
    }


def faults_document(report: FaultReport) -> dict:
    """The `verify --faults --json` document: per injected fault whether the block stayed bit-exact, finite,
    within the clamp and rate, flagged it, was clear again at the end; constants check, what was unsafe."""
    return {
        "format": "thermoplc-verify-faults", "version": VERSION, "ok": report.ok, "block": report.block,
        "rows": report.rows,
        "cases": [{"fault": c.kind.name, "sensor": c.sensor, "first_row": c.first_row, "last_row": c.last_row,
                   "ok": c.ok, "bit_exact": c.bit_exact, "finite": c.finite, "within_clamp": c.within_clamp,
                   "within_rate": c.within_rate, "flagged": c.flagged, "clear_at_end": c.clear_at_end,
                   "max_change": c.max_change if math.isfinite(c.max_change) else str(c.max_change),
                   "runtime_error": c.failure, "safe": c.safe,
                   "error": None if c.harm is None else c.harm.worst,
                   "error_row": None if c.harm is None else c.harm.worst_row,
                   "none_error": None if c.harm is None else c.harm.none} for c in report.cases],
        "constants": {"checked": report.constants_checked, "differ": list(report.constant_errors)},
        "unsafe": list(report.unsafe),
        "not_run": list(report.not_run),
    }


def diff_document(result: BlockDiff, with_data: bool) -> dict:
    """The `diff --json` document: the structural differences and, with data (`with_data`), the outputs that
    behave differently; `same` only when the structure, and with data the behaviour, agree."""
    behaviour = None if result.behaviour is None else [
        {"output": d.output, "type": d.type,
         "max_abs": (d.max_abs if math.isfinite(d.max_abs) else str(d.max_abs)) if d.real else None,
         "first_cycle": d.cycle, "time_s": d.time, "differing_calls": d.differing_calls} for d in result.behaviour]
    same = result.structurally_equal and (not with_data or result.behaviour_equal)
    return {
        "format": "thermoplc-diff", "version": VERSION, "same": same, "old": result.old, "new": result.new,
        "structurally_equal": result.structurally_equal,
        "header": list(result.header), "interface": list(result.interface),
        "constants": [{"name": c.name, "old": value(c.old), "new": value(c.new)} for c in result.constants],
        "statements": list(result.statements),
        "behaviour": behaviour, "cycles": result.cycles,
    }
