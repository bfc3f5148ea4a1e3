"""The library's `generate`: a model file's model becomes block text only after every check the
command line makes (the acceptance gate, the static range proof, the stress replay), so the CLI,
the demo and a user's script write the same, checked blocks."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.base.version import __version__
from thermoplc.contract.constants import expected
from thermoplc.generator.dialects import plcopen_wrapped, recognized
from thermoplc.generator.ir import Block, Identity
from thermoplc.generator.lower import lower, prove
from thermoplc.generator.printer import (DIALECTS, GenerationError, render, render_instance_db, render_plcopen,
                                        validate)
from thermoplc.generator.ranges import RangeProof
from thermoplc.fitting.acceptance import problem, quantisation_problem
from thermoplc.models.model import Model
from thermoplc.models.safety import Limits
from thermoplc.contract.outputs import output_unit
from thermoplc.generator.testbench import (ELEMENT_BYTES, ROWS_PER_CYCLE, BenchPlan, Port, bench_names, chunks,
                                         default_calls)
from thermoplc.generator.testbench_text import render_bench
from thermoplc.recordings.table import Table
from thermoplc.verifier.replays.bench_run import BenchCounters, data_arrays, run_bench
from thermoplc.verifier.reading.bench_source import parse_sources
from thermoplc.verifier.reading.block_file import read_source
from thermoplc.verifier.replays.expectation import model_expectation, window
from thermoplc.verifier.reading.parser import parse_text
from thermoplc.verifier.reading.plcopen import is_xml, read_plcopen
from thermoplc.verifier.replays.replay import block_limits, check_period, load_block
from thermoplc.verifier.reading.syntax import Program, Sources
from thermoplc.verifier.replays.stress import StressResult, stress


@dataclass(frozen=True)
class Generated:
    """A checked block: its text, its IR, and the evidence that it is safe to write."""
    text: str
    block: Block
    proof: RangeProof
    stressed: StressResult
    unvalidated: str | None  # why the model has not earned a block, when accept_unvalidated let it through


def becomes_block(model: Model, path: str) -> None:
    """Refuse to write a model file that no block can be made of: fit and diagnose check it before
    writing, so that a column named like one of the block's own variables (`Ready`, `K0_1`) is
    refused there and not only by `generate`. The block is lowered and checked by the rules every
    rendering checks (printer.validate); no text is rendered, no range proof or gate is run."""
    problem = block_problem(model)
    if problem:
        raise UserError(f"{path}: not written: the model could not become a block: {problem}; rename the column "
                        f"or the block")


def block_problem(model: Model) -> str | None:
    """Why no block can be made of `model` (lowered and checked as becomes_block checks it), or None."""
    try:
        validate(lower(model))
    except GenerationError as exc:
        return str(exc)
    return None


def accepted(model: Model, source: str, accept_unvalidated: bool = False) -> str | None:
    """Refuse a model that has not earned a block (no held-out evidence, or not clearly better than
    no compensation) unless accept_unvalidated; refuse, always, a float32 block that is not the
    model that was judged. Returns why the model is unvalidated when the flag let it through."""
    try:
        drift, why = quantisation_problem(model), problem(model)
    except UserError as exc:  # a malformed metrics field
        raise UserError(f"{source}: {exc}") from None
    if drift:
        raise UserError(f"{source}: {drift}; nothing written")
    if why and not accept_unvalidated:
        raise UserError(f"{source}: {why}; nothing written (--accept-unvalidated writes it anyway, and the "
                        "header says so)")
    return why


def generate(model: Model, source: str = "model", limits: Limits | None = None, dialect: str = "tia",
             plcopen: bool = False, identity: Identity | None = None, retain: bool = False,
             instance_db: str | None = None, accept_unvalidated: bool = False, output: str = "block") -> Generated:
    """The block for `model` as text of `dialect` (PLCopen XML around the iec dialect with `plcopen`),
    or a UserError naming `source` (the model file) when any check refuses it; `output` names the
    text in what the stress replay reports; `limits` None: Limits.for_model(model), from its recording's envelope."""
    limits = Limits.for_model(model) if limits is None else limits
    if dialect not in DIALECTS:
        raise UserError(f"dialect {dialect!r}: expected one of {', '.join(DIALECTS)}")
    if plcopen and not DIALECTS[dialect].plcopen:
        raise UserError(f"--format plcopen wraps the {plcopen_wrapped().name} dialect; add --dialect "
                        f"{plcopen_wrapped().name}")
    if instance_db is not None and not DIALECTS[dialect].instance_db:
        raise UserError(f"--instance-db writes a {_titles(True)} instance DB source; {_titles(False)} targets "
                        f"create the instance when the block is called")
    unvalidated = accepted(model, source, accept_unvalidated)
    try:
        block = lower(model, limits, identity, retain)
        text = render_plcopen(block, __version__) if plcopen else render(block, dialect)
        if instance_db is not None:
            text += render_instance_db(block, instance_db, dialect)
    except GenerationError as exc:
        raise UserError(f"{source}: cannot generate a block: {exc}") from None
    except UserError as exc:  # a coefficient the kind needs is missing
        raise UserError(str(exc).replace("model file:", f"{source}:", 1)) from None
    written = [c.name for c in block.constants] + [v.name for v in block.statics if v.initial is not None]
    unused = expected(model, limits, written)[2]
    if unused:  # verify would find them in no constant or table: the file is not what its kind writes
        raise UserError(f"{source}: field 'coefficients': {', '.join(unused[:5])}{' ...' if len(unused) > 5 else ''} "
                        f"not used by a {model.kind} model; was the file edited, or its 'kind' changed?")
    proof = prove(model, block, limits)
    if proof.problems:
        more = f" (and {len(proof.problems) - 3} more)" if len(proof.problems) > 3 else ""
        raise UserError(f"{source}: the range proof fails with every input inside its guard range: "
                        + "; ".join(proof.problems[:3]) + more + "; nothing written")
    program = read_plcopen(text, output) if plcopen else parse_text(text, output)  # what is written is stressed
    stressed = stress(program, model, limits, output)
    if stressed.problems:
        raise UserError(f"{source}: the block reaches a value that must not reach the NC with every input inside its "
                        f"guard range (stress replay): " + "; ".join(stressed.problems[:3]) + "; nothing written")
    return Generated(text, block, proof, stressed, unvalidated)


@dataclass(frozen=True)
class Bench:
    """A test bench's source, what it holds, and its run in thermoplc's interpreter."""
    text: str
    name: str  # the bench block's
    dialect: str
    plcopen: bool  # PLCopen XML of the iec dialect
    first: int  # the data row of call 1, counted from 0
    plan: BenchPlan
    data_blocks: int
    largest_bytes: int
    counters: BenchCounters


def _titles(instance_db: bool) -> str:
    """The dialects that write an instance DB beside the block, or those that do not, as a sentence names them."""
    titles = [record.title for record in DIALECTS.values() if bool(record.instance_db) == instance_db]
    return " and ".join(filter(None, (", ".join(titles[:-1]), titles[-1])))


def block_dialect(block_path: str) -> tuple[str, bool]:
    """The dialect a block source is written in, as each dialect's record recognizes it (TIA's optimized-access
    attribute, STEP 7's quoted name without it, IEC's bare name), and whether it is PLCopen XML (of the dialect
    it wraps)."""
    text = read_source(block_path)
    if is_xml(text):
        return plcopen_wrapped().name, True
    return recognized(text), False


def testbench(block_path: str, model: Model, model_path: str, table: Table, first: int = 0, calls: int | None = None,
              rows_per_cycle: int | None = None, tolerance: float = 0.0, overrides: dict | None = None,
              probe_every=None) -> Bench:
    """The test bench of the block at `block_path`, in its dialect, over rows `first` (from 0) .. of `table`; the
    expected outputs the model's float32 reference from a Reset at the window's first row; `tolerance` in um
    (urad for an angle, a thousandth of it for a K0 output in mm). Run here, in thermoplc's interpreter, before
    it is returned (`Bench.counters`)."""
    program, replayer = load_block(block_path, "interp")
    dialect, plcopen = block_dialect(block_path)
    check_period(model, table)
    seen = model_expectation(block_path, program, replayer, block_limits(program, block_path), model, model_path,
                             table, overrides, probe_every)
    if not 0 <= first < table.rows:
        raise UserError(f"--from {first + 1}: {table.path} has rows 1 to {table.rows}")
    outputs = [d for d in replayer.outputs if d.name not in program.per_call]
    row_bytes = sum(ELEMENT_BYTES[d.type.base] for d in (*replayer.inputs, *outputs))
    calls = default_calls(row_bytes, table.rows - first, dialect) if calls is None else calls
    if not 1 <= calls <= table.rows - first:
        left = table.rows - first
        raise UserError(f"--calls {calls}: {table.path} has {left} row{'s' if left != 1 else ''} from row {first + 1}")
    columns, expected = window(seen, model, first, calls)
    as_values = lambda d, values: tuple(float(x) if d.type.base == "REAL" else bool(x) if d.type.base == "BOOL"
                                        else int(x) for x in np.asarray(values).tolist())
    plan = BenchPlan(program.name, tuple(Port(d.name, d.type.base, as_values(d, columns[d.name]))
                                         for d in replayer.inputs),
                     tuple(Port(d.name, d.type.base, as_values(d, expected[d.name]), _tolerance(d, tolerance))
                           for d in outputs),
                     rows_per_cycle or ROWS_PER_CYCLE[dialect],
                     bench_notes(expected, model_path, table, first, calls, program))
    try:
        text = render_bench(plan, dialect, plcopen, __version__)
        parts = chunks(plan, dialect)
    except GenerationError as exc:
        raise UserError(f"{block_path}: no test bench: {exc}") from None
    name = bench_names(program.name)[0]
    counters = run_bench_text(text, f"{name} (the test bench)", program, block_path,
                              math.ceil(calls / plan.rows_per_cycle) + 1, plcopen)
    largest = max(part.rows for part in parts) * (plan.row_bytes + 1)
    return Bench(text, name, dialect, plcopen, first, plan, len(parts), largest, counters)


def _tolerance(output, tolerance_um: float) -> float:
    """An output's tolerance in its own unit, a REAL: um (urad for an angle); a K0 output is in mm."""
    if output.type.base != "REAL" or not tolerance_um:
        return 0.0
    return float(np.float32(tolerance_um / 1000 if output_unit(output.name) == "mm" else tolerance_um))


def run_bench_text(text: str, source: str, block: Program, block_path: str, max_cycles: int,
                   plcopen: bool = False) -> BenchCounters:
    """A test bench's source (PLCopen XML with `plcopen`) run in thermoplc's interpreter against the parsed
    block under test."""
    sources = Sources((read_plcopen(text, source, bench=True),), ()) if plcopen else parse_sources(text, source)
    benches = [b for b in sources.blocks if b.name.upper() != block.name.upper()]
    if len(benches) != 1:
        raise UserError(f"{source}: expected one test bench function block besides {block.name}, found "
                        f"{', '.join(b.name for b in benches) or 'none'}")
    blocks = {block.name: (block, block_path), **{b.name: (b, source) for b in sources.blocks}}
    return run_bench(benches[0], source, blocks, data_arrays(sources.data_blocks, source), max_cycles)


def bench_notes(expected: dict, model_path: str, table: Table, first: int, calls: int,
                program: Program) -> tuple[str, ...]:
    """The bench's header: where its rows come from, how it starts, what '=' cannot see."""
    negative_zero = sum(int(np.count_nonzero((values == 0) & np.signbit(values)))
                        for values in map(np.asarray, expected.values()) if values.dtype.kind == "f")
    lines = table.lines
    notes = [f"Calls 1 to {calls} are rows {first + 1} to {first + calls} of {Path(table.path).name} (lines "
             f"{int(lines[first])} to {int(lines[first + calls - 1])}): call k is row {first} + k"
             + ("; verify names it cycle k - 1." if first == 0 else "."),
             f"Expected: the float32 reference of {Path(model_path).name}, the block Reset at call 1 (a new "
             f"instance's state), then driven as recorded.",
             "Call this block from a cyclic OB or task: RowsPerCycle calls of the block per cycle, until Done.",
             "It runs once, on a new instance: download it with its instance data initialised to run it again.",
             "REAL outputs are compared with '=' (BOOL with XOR): '=' does not tell -0.0 from 0.0 "
             f"({negative_zero} expected values here are -0.0) and counts any NaN as a mismatch."]
    if program.per_call:
        notes.append(f"{', '.join(program.per_call)} is not compared: the PLC sets it on every call.")
    return tuple(notes)
