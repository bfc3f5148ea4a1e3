"""Stress replay at generate: the emitted block run on inputs that stay inside their guard ranges but
go to the corners (held for a while, jumping between extremes, the speed at standstill and at its
limit), with every NaN, Inf and integer overflow reported by the interpreter's rules.

This is a search for counterexamples, not a proof: a block that passes can still reach a value the
stress sequence never visited. It catches what a hostile or careless model file brings (a
coefficient of 1e38, a division that reaches 0 at an extreme temperature) before the block is
written, and gives the output range it saw.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thermoplc.models.model import Model
from thermoplc.contract.outputs import ENABLE_INPUT, PROBE_NEW_INPUT, PROBE_VALUE_INPUT, RESET_INPUT
from thermoplc.models.safety import Limits, guards
from thermoplc.verifier.engines.choice import Replayer
from thermoplc.verifier.replays.replay import unsafe_findings
from thermoplc.verifier.reading.syntax import Program

STRESS_ROWS = 6000
STRESS_SEED = 61131


@dataclass(frozen=True)
class StressResult:
    rows: int
    problems: tuple[str, ...]  # "line:col: NaN ('/' gives NaN) from stress call 12"
    output_ranges: dict  # REAL output -> (min, max) seen


def stress_inputs(model: Model, limits: Limits, rows: int = STRESS_ROWS, seed: int = STRESS_SEED) -> dict:
    """Per block input a float32 column: segments of 1..300 calls holding the low end, the high end,
    the middle or a random value of the input's guard range (speed also at 0); Reset and Enable at random."""
    rng = np.random.default_rng(seed)
    constants = limits.values()
    columns = {}
    for g in guards(model):
        low, high = float(constants[g.low]), float(constants[g.high])
        choices = [low, high, (low + high) / 2] + ([0.0] if g.low == "speed_min" else [])
        values = np.empty(rows)
        row = 0
        while row < rows:
            length = int(rng.integers(1, 300))
            pick = int(rng.integers(0, len(choices) + 1))
            values[row:row + length] = choices[pick] if pick < len(choices) else rng.uniform(low, high)
            row += length
        columns[g.name] = values.astype(np.float32)
    columns[RESET_INPUT] = rng.random(rows) < 0.01  # about every 100 calls a restart
    columns[ENABLE_INPUT] = rng.random(rows) >= 0.05  # and a skipped call now and then
    if model.probe is not None:
        columns.update(_hostile_probings(model, rows, np.random.default_rng(seed + 1)))
    return columns


def _hostile_probings(model: Model, rows: int, rng) -> dict:
    """A probing every few calls, at the limit's ends, 0, beyond the limit, NaN, Inf or a random value, some stuck
    for many probings: what a hostile or broken probing cycle sends."""
    limit = float(model.probe.values()["limit_um"])
    choices = np.array([limit, -limit, 0.0, 1000.0 + 2 * limit, np.nan, np.inf, -np.inf], np.float64)
    picks = rng.integers(0, len(choices) + 1, rows)
    values = np.where(picks < len(choices), choices[np.minimum(picks, len(choices) - 1)], rng.uniform(-limit, limit, rows))
    stuck = rng.random(rows) < 0.3  # the cycle repeats its last result
    for j in np.flatnonzero(stuck[1:]) + 1:
        values[j] = values[j - 1]
    return {PROBE_VALUE_INPUT: values.astype(np.float32), PROBE_NEW_INPUT: rng.random(rows) < 0.3}


def stress(program: Program, model: Model, limits: Limits, source: str) -> StressResult:
    replayer = Replayer(program, source, "auto")
    declared = {d.name for d in replayer.inputs}
    inputs = {name: column for name, column in stress_inputs(model, limits).items() if name in declared}
    outputs = tuple(d.name for d in replayer.outputs)
    produced = replayer.replay(inputs, STRESS_ROWS, outputs)
    problems = tuple(f"{source}:{f.pos[0]}:{f.pos[1]}: {label} ({f.detail}) from stress call {f.first_cycle}"
                     for f, label in unsafe_findings(replayer.machine.findings.values()))
    ranges = {d.name: (float(np.min(produced[d.name])), float(np.max(produced[d.name])))
              for d in replayer.outputs if d.type.base == "REAL"}
    return StressResult(STRESS_ROWS, problems, ranges)
