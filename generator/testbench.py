"""A test bench for the PLC itself: the recorded inputs and the float32 reference's outputs held in data
(data blocks on Siemens targets, constant arrays elsewhere), cut to fit each target's limits, and a
function block that calls the block under test once per recorded row and compares every output.
Knows the block's interface and the values, nothing about models (generator/testbench_text.py prints it)."""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

from thermoplc.base.binary32 import is_f32
from thermoplc.base.identifiers import MAX_LENGTH, identifier_problem
from thermoplc.generator.ir import GenerationError

ELEMENT_BYTES = {"REAL": 4, "INT": 2, "BOOL": 1}  # a BOOL counted as a byte: what an optimized DB gives it
MAX_CALLS = 32767  # the counters are INT: every S7-300 CPU has INT arithmetic on them
MAX_CHUNKS = 99


@dataclass(frozen=True)
class Target:
    """What one data block (or one constant array) may hold, and why."""
    chunk_bytes: int
    download_bytes: int  # the data a default test bench holds: one download on the smallest CPU of the family
    why: str


TARGETS = {
    "tia": Target(65536, 262144, "an S7-1200/1500 DB of at most 64 KiB (an S7-1200's limit); 256 KiB in all"),
    "step7": Target(65536, 262144, "an S7-300/400 DB of at most 64 KiB; 256 KiB in all (an S7-315's work memory)"),
    "iec": Target(65536, 262144, "CODESYS/OpenPLC constant arrays of at most 64 KiB each; 256 KiB in all"),
}


@dataclass(frozen=True)
class Port:
    """One input the bench gives the block, or one output it checks, with its value at every call."""
    name: str
    type: str  # REAL, BOOL or INT
    values: tuple


@dataclass(frozen=True)
class BenchPlan:
    """Everything a test bench holds, in no dialect's syntax."""
    block: str  # the block under test
    inputs: tuple[Port, ...]
    outputs: tuple[Port, ...]  # the expected values
    rows_per_cycle: int
    tolerance: float  # 0: every REAL output compared with '='; else |actual - expected| <= this passes
    notes: tuple[str, ...]  # header lines: where the rows come from, what the counters mean

    @property
    def calls(self) -> int:
        return len(self.inputs[0].values) if self.inputs else 0

    @property
    def row_bytes(self) -> int:
        return sum(ELEMENT_BYTES[p.type] for p in (*self.inputs, *self.outputs))


@dataclass(frozen=True)
class Chunk:
    """Rows `first` .. `first + rows - 1` of the bench, in one data block (or one set of arrays)."""
    number: int
    first: int
    rows: int


def bench_names(block: str) -> tuple[str, str]:
    """The bench's block name and its data blocks' prefix: within the 24 characters every dialect keeps
    (STEP 7's symbol limit), a long block name cut with a digest so two long names stay apart."""
    base = block if len(block) <= MAX_LENGTH - 8 else \
        f"{block[:MAX_LENGTH - 13]}_{hashlib.sha256(block.encode()).hexdigest()[:4]}"
    return f"{base}_TB", f"{base}_TB_D"


def default_calls(row_bytes: int, rows: int, dialect: str) -> int:
    """Calls that fit one download on `dialect`'s smallest target (TARGETS), at most the rows there are."""
    return max(1, min(rows, TARGETS[dialect].download_bytes // row_bytes, MAX_CALLS))


def chunks(plan: BenchPlan, dialect: str) -> tuple[Chunk, ...]:
    """The rows cut into data blocks within the target's size limit."""
    per_chunk = TARGETS[dialect].chunk_bytes // (plan.row_bytes + 1)  # +1: a byte of alignment per array and row
    per_chunk = max(1, per_chunk - 2)
    count = math.ceil(plan.calls / per_chunk)
    if count > MAX_CHUNKS:
        raise GenerationError(f"{plan.calls} calls need {count} data blocks of at most "
                              f"{TARGETS[dialect].chunk_bytes:,} bytes; at most {MAX_CHUNKS} are written: "
                              f"give fewer --calls")
    return tuple(Chunk(k + 1, k * per_chunk, min(per_chunk, plan.calls - k * per_chunk)) for k in range(count))


def check_plan(plan: BenchPlan) -> None:
    """Refuse what no PLC could run or compare: no calls, too many, unequal columns, a value its type
    cannot hold, a NaN or infinite value (`=` never matches a NaN), an unusable name."""
    if not 1 <= plan.calls <= MAX_CALLS:
        raise GenerationError(f"{plan.calls} calls; a test bench makes 1 to {MAX_CALLS} (its counters are INT)")
    if not 1 <= plan.rows_per_cycle <= 1000:
        raise GenerationError(f"{plan.rows_per_cycle} rows per PLC cycle; expected 1 to 1000")
    if not (math.isfinite(plan.tolerance) and plan.tolerance >= 0 and is_f32(plan.tolerance)):
        raise GenerationError(f"tolerance {plan.tolerance!r}: expected a finite REAL >= 0")
    problem = identifier_problem(plan.block)
    if problem:
        raise GenerationError(f"block name {plan.block!r} {problem}")
    for port in (*plan.inputs, *plan.outputs):
        if len(port.values) != plan.calls:
            raise GenerationError(f"{port.name}: {len(port.values)} values for {plan.calls} calls")
        if port.type not in ELEMENT_BYTES:
            raise GenerationError(f"{port.name}: type {port.type}; a test bench holds REAL, BOOL and INT")
        if port.type == "REAL":
            bad = next((v for v in port.values if not (math.isfinite(v) and is_f32(v))), None)
            if bad is not None:
                raise GenerationError(f"{port.name}: the value {bad!r} is no finite REAL; '=' cannot compare it")
