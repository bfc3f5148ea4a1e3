"""A test bench for the PLC itself: the recorded inputs and the float32 reference's outputs held in data
(data blocks on Siemens targets, constant arrays elsewhere), cut to fit each target's limits, and a
function block that calls the block under test once per recorded row and compares every output.
Knows the block's interface and the values, nothing about models (generator/testbench_text.py prints it)."""
from __future__ import annotations

import hashlib
import math
import re
from dataclasses import dataclass

from thermoplc.base.binary32 import FLT_MIN_NORMAL, is_f32
from thermoplc.base.identifiers import MAX_LENGTH, identifier_problem
from thermoplc.generator.dialects import registry
from thermoplc.generator.ir import GenerationError

ELEMENT_BYTES = {"REAL": 4, "INT": 2, "BOOL": 1}  # a BOOL counted as a byte: what an optimized DB gives it
MAX_CALLS = 32767  # the counters are INT: every S7-300 CPU has INT arithmetic on them
MAX_CHUNKS = 99


TARGETS = {name: record.bench for name, record in registry().items()}  # what one data block may hold, by dialect
ROWS_PER_CYCLE = {name: record.rows_per_cycle for name, record in registry().items()}  # calls per PLC cycle
BENCH_VARIABLES = ("Done", "Calls", "Mismatches", "FirstMismatchCall", "FirstMismatchOutput", "FirstExpected",
                   "FirstActual", "MaxDiff", "Dut", "Pass", "Row", "Differs", "Diff", "CallCount", "RowsPerCycle")


@dataclass(frozen=True)
class Port:
    """One input the bench gives the block, or one output it checks, with its value at every call."""
    name: str
    type: str  # REAL, BOOL or INT
    values: tuple
    tolerance: float = 0.0  # a REAL output: |block - expected| <= this passes (in the output's unit); 0: '='


@dataclass(frozen=True)
class BenchPlan:
    """Everything a test bench holds, in no dialect's syntax."""
    block: str  # the block under test
    inputs: tuple[Port, ...]
    outputs: tuple[Port, ...]  # the expected values
    rows_per_cycle: int
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


def rows_per_chunk(row_bytes: int, dialect: str) -> int:
    """Rows one data block (or one set of arrays) holds within the target's limit, a byte of alignment per
    array and row counted."""
    return max(1, TARGETS[dialect].chunk_bytes // (row_bytes + 1) - 2)


def default_calls(row_bytes: int, rows: int, dialect: str) -> int:
    """Calls whose data fill at most the dialect's budget (TARGETS), at most the rows there are."""
    target = TARGETS[dialect]
    return max(1, min(rows, rows_per_chunk(row_bytes, dialect) * (target.download_bytes // target.chunk_bytes),
                      MAX_CALLS))


def chunks(plan: BenchPlan, dialect: str) -> tuple[Chunk, ...]:
    """The rows cut into data blocks within the target's size limit."""
    per_chunk = rows_per_chunk(plan.row_bytes, dialect)
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
    problem = identifier_problem(plan.block)
    if problem:
        raise GenerationError(f"block name {plan.block!r} {problem}")
    taken = {name.upper() for name in (*BENCH_VARIABLES, *bench_names(plan.block))}
    if plan.block.upper() in taken or re.fullmatch(r"(?i)(In|Exp|Tol)[0-9]+|D[0-9]+_\w*", plan.block):
        raise GenerationError(f"block name {plan.block!r} is also the name of a variable of its test bench; "
                              f"generate the block with another --name")
    for port in (*plan.inputs, *plan.outputs):
        if len(port.values) != plan.calls:
            raise GenerationError(f"{port.name}: {len(port.values)} values for {plan.calls} calls")
        if port.type not in ELEMENT_BYTES:
            raise GenerationError(f"{port.name}: type {port.type}; a test bench holds REAL, BOOL and INT")
        if port.type == "REAL":
            bad = next((v for v in port.values if not (math.isfinite(v) and is_f32(v))), None)
            if bad is not None:
                raise GenerationError(f"{port.name}: the value {bad!r} is no finite REAL; '=' cannot compare it")
        tolerance = port.tolerance
        if tolerance and not (port.type == "REAL" and is_f32(tolerance) and FLT_MIN_NORMAL <= tolerance <= 1e6):
            raise GenerationError(f"{port.name}: tolerance {tolerance!r}; expected 0 or a normal REAL of at most 1e6 "
                                  f"(a REAL output's)")
