"""Replay recorded rows through a parsed block and compare every output bit for bit."""
from __future__ import annotations

import re
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from thermoplc.base.binary32 import f32_bits, f32_hex, is_subnormal, ulp_distance
from thermoplc.contract.constants import (LIMIT_NAMES, TABLE_PREFIX, constant_name, expected, limits_of_block,
                                          required)
from thermoplc.contract.outputs import FAULT_PREFIX, PROBE_INPUTS, control_of
from thermoplc.base.errors import UserError
from thermoplc.fitting.fit import SAMPLING_TOLERANCE, sample_period
from thermoplc.models.model import Model
from thermoplc.models.reference import block_outputs
from thermoplc.models.safety import Limits
from thermoplc.recordings.table import Table, close_match
from thermoplc.verifier.replays.control import control_summary, unread_control_columns
from thermoplc.verifier.engines.contraction import Contraction, contraction
from thermoplc.verifier.engines.choice import Replayer
from thermoplc.verifier.replays.expectation import model_expectation
from thermoplc.verifier.replays.mapping import known_overrides
from thermoplc.verifier.engines.semantics import BlockFailure, Finding
from thermoplc.verifier.reading.block_file import parse_file
from thermoplc.verifier.replays.probings import reference_keys, start_value_errors, summary as probing_summary
from thermoplc.verifier.reading.syntax import Program, names_read
from thermoplc.verifier.engines.typed import cells_as, differing_rows, first_non_finite

ARRAY_ITEMS_SHOWN = 6
FINDING_LABELS = (("subnormal", "subnormal"), ("nan", "NaN"), ("inf", "Inf"),
                  ("non-portable", "non-portable operations"), ("literal", "literals in expressions"),
                  ("int-overflow", "INT overflow"))


@dataclass(frozen=True)
class Mismatch:
    cycle: int
    row_line: int  # line in the CSV file
    time: float
    output: str
    block_value: object
    expected_value: object
    variables: dict


@dataclass(frozen=True)
class Report:
    block: str
    against: str  # what the block was compared with
    data: str
    cycles: int
    outputs: tuple[str, ...]
    mismatch: Mismatch | None
    findings: tuple[Finding, ...]
    seconds: float
    quantisation_um: dict = field(default_factory=dict)  # output -> max |float32 - float64|
    constants_checked: int = 0
    constant_errors: tuple[str, ...] = ()  # block constants/tables that differ from the model
    limits: Limits | None = None  # safety limits read from the block (model verification)
    engine: str = "interp"  # the engine that produced the compared outputs
    engine_note: str = ""  # why the fast engine was not used, when asked for
    unsafe: tuple[str, ...] = ()  # a non-finite REAL output or an INT overflow: fails whatever the reference says
    control: str = ""  # a note on the data: how it drove Enable and Reset, or what a trace must hold
    failure: str | None = None  # the block's run-time error (an index outside its array...): it is not the model
    # what the block output at each call, as replayed (verify --outputs writes it); empty from the streamed route
    produced: dict = field(default_factory=dict, repr=False, compare=False)
    origin: str = ""  # the block's header names another model than the one it is compared with (said first)
    contraction: Contraction | None = None  # what a target that fuses multiply-adds shows (a bit-exact block)

    @property
    def ok(self) -> bool:
        return self.mismatch is None and not self.constant_errors and not self.unsafe and self.failure is None

    def text(self) -> str:
        lines = []
        if self.ok:
            lines.append(f"bit-exact: {self.block} reproduces {self.against} on {self.data}")
            lines.append(f"  {self.cycles} cycles, {self.cycles * len(self.outputs)} outputs compared "
                         f"({', '.join(self.outputs)}): every bit equal")
            if self.control:
                lines.append(f"  {self.control}")
        elif self.failure is not None:
            lines.append(f"NOT bit-exact: {self.block} stops with a run-time error on {self.data}, where "
                         f"{self.against} computes every call: {self.failure}")
        elif self.mismatch is None and self.constant_errors:
            lines.append(f"NOT bit-exact: {self.block} holds constants that differ from the model "
                         f"(the {self.cycles} replayed cycles matched)")
        elif self.mismatch is None:
            lines.append(f"NOT verified: {self.block} matches {self.against} on {self.data}, but a value it "
                         f"produced must not reach the NC")
        else:
            m = self.mismatch
            lines.append(f"NOT bit-exact: {self.block} differs from {self.against} on {self.data}")
            lines.append(f"  first divergent cycle {m.cycle} (line {m.row_line} of the data, time {m.time:g} s), "
                         f"output {m.output}:")
            lines.append(f"    block     {_show(m.block_value)}")
            lines.append(f"    expected  {_show(m.expected_value)}")
            if isinstance(m.block_value, float) and isinstance(m.expected_value, float):
                lines.append(f"    distance  {ulp_distance(m.block_value, m.expected_value)} ULP")
            lines.append(f"  block variables at cycle {m.cycle} (cycles count from 0):")
            lines.extend(f"    {name} = {_show(value)}" for name, value in m.variables.items())
            if self.control:
                lines.append(f"  {self.control}")
        lines.extend(f"  UNSAFE: {u}" for u in self.unsafe)
        if self.constants_checked:
            lines.extend(f"  {line}" for line in constants_lines(self.constants_checked, self.constant_errors))
        if self.limits is not None:
            lim = self.limits
            lines.append(f"  safety limits read from the block: outputs within +-{lim.max_output:g}, at most "
                         f"{lim.max_step:g} per call; temperatures {lim.temp_min_C:g}..{lim.temp_max_C:g} degC, "
                         f"jump {lim.max_jump_K:g} K"
                         + (f", stuck after {lim.stuck_calls} repeats of a reading" if lim.stuck_calls else "")
                         + f", trusted again after {lim.settle_calls} steady calls; "
                         + (f"while a fault bit is set within {lim.fault_move:g} of the output before it, fading by "
                            f"{lim.fault_fade:.9g} per call"
                            if lim.fault_move is not None else "no fault hold (a block generated before it)"))
        for name, error in self.quantisation_um.items():
            lines.append(f"  max |float32 - float64| on {name}: {error:.6g} um")
        if self.contraction is not None:
            lines.append(f"  {self.contraction.line()}")
        found = {kind: [f for f in self.findings if f.kind == kind] for kind, _ in FINDING_LABELS}
        lines.append("  " + "; ".join(f"{label}: {len(found[kind]) or 'none'}" for kind, label in FINDING_LABELS))
        for kind, label in FINDING_LABELS:
            for f in found[kind][:10]:
                when = f", {f.count} time(s) from cycle {f.first_cycle}" if f.first_cycle is not None else ""
                lines.append(f"    {self.block}:{f.pos[0]}:{f.pos[1]}: {f.detail}{when}")
        if any(f.kind in ("non-portable", "literal") for f in self.findings):
            lines.append("  WARNING: the proof does not carry over to a PLC for the places listed above (numeric contract "
                         "rules 2 and 4, docs/numeric_contract.md)")
        rate = self.cycles / self.seconds if self.seconds > 0 else float("inf")
        engine = "fast engine (compiled C)" if self.engine == "fast" else "interpreter"
        lines.append(f"  replay: {self.seconds:.2f} s, {rate:,.0f} cycles/s, {engine}")
        if self.engine_note:
            lines.append(f"  note: {self.engine_note}")
        if self.origin and not self.ok:  # the likeliest cause of every difference above: said beneath the verdict
            lines.insert(1, f"  NOTE: {self.origin}")
        return "\n".join(lines)


def constants_lines(checked: int, errors: tuple[str, ...]) -> list[str]:
    """How many declared values compare_constants checked, and the first 20 that differ (indented)."""
    differ = "none differ" if not errors else "1 differs" if len(errors) == 1 else f"{len(errors)} differ"
    return [f"constants and tables: {checked} values checked against the model, {differ}",
            *(f"  {e}" for e in errors[:20])]


def _show(value) -> str:
    if isinstance(value, bool) or value is None:
        return str(value).upper()
    if isinstance(value, float):
        return f"{str(np.float32(value))} ({f32_hex(value)})"
    if isinstance(value, list):
        shown = ", ".join(_show(v) for v in value[:ARRAY_ITEMS_SHOWN])
        return f"[{shown}{', ...' if len(value) > ARRAY_ITEMS_SHOWN else ''}] ({len(value)} values)"
    return repr(value)


def load_block(block_path: str, engine: str = "auto") -> tuple[Program, Replayer]:
    """The parsed block and the machine that runs it on the chosen engine (interpreter or native C)."""
    program = parse_file(block_path)
    return program, Replayer(program, str(block_path), engine)


def block_columns(inputs: list, table: Table, overrides: dict | None, block: str, probings: str = "") -> dict:
    """The data column of each block input (by its name unless --inputs maps it), REAL as float32; `probings`
    says where else a fused block's probing inputs may come from (diff: --probe-target)."""
    overrides = known_overrides(overrides, [d.name for d in inputs], block)
    columns = {}
    for d in inputs:
        column = overrides.get(d.name, d.name)
        if column not in table.columns and d.initial is not None and d.name not in overrides:
            continue  # unwired: the input keeps its start value (Enable TRUE, Reset FALSE)
        if column not in table.columns:
            probing = d.name.upper() in {name.upper() for name in PROBE_INPUTS.values()}
            where = (f"a fused block replays its probings from columns {' and '.join(PROBE_INPUTS.values())}"
                     f"{probings}, or map them with --inputs {d.name}=COLUMN" if probing else
                     f"map it with --inputs {d.name}=COLUMN")
            raise UserError(f"{table.path}: no column {column!r} for input {d.name} of {block}"
                            f"{close_match(column, table.columns)}; {where}")
        columns[d.name] = cells_as(table, column, d.type.base, f"input {d.name} of {block}")
    return columns


def _first_mismatch(produced: dict, expected: dict, types: dict) -> tuple[int, str] | None:
    first = None
    for name in produced:
        differ = differing_rows(types[name], produced[name], expected[name])
        if len(differ) and (first is None or differ[0] < first[0]):
            first = (int(differ[0]), name)
    return first


def unsafe_findings(findings, finite_inputs: bool = True) -> list[tuple[Finding, str]]:
    """Run-time findings that must never pass, with their label: INT overflow and subnormal values
    (a PLC that flushes them to zero computes otherwise) always, NaN and Inf when the inputs were
    finite."""
    kinds = ("int-overflow", "subnormal", "nan", "inf") if finite_inputs else ("int-overflow", "subnormal")
    return [(f, label) for f in findings for kind, label in FINDING_LABELS
            if kind in kinds and f.kind == kind and f.first_cycle is not None]


def subnormal_declarations(decls, block: str) -> list[str]:
    """Declared REAL values (constants, start values, table entries) that are subnormal: a PLC that
    flushes them to zero computes with 0, whatever the replay here shows."""
    found = []
    for d in decls:
        values = d.initial if isinstance(d.initial, tuple) else (d.initial,)
        found += [f"{block}:{d.pos[0]}:{d.pos[1]}: {d.name}{f'[{k}]' if len(values) > 1 else ''} is declared "
                  f"with the subnormal value {v!r} (a PLC that flushes subnormals reads 0)"
                  for k, v in enumerate(values) if d.type.base == "REAL" and isinstance(v, float) and is_subnormal(v)]
    return found


def _unsafe(produced: dict, types: dict, findings, table: Table, block: str, inputs: dict) -> tuple[str, ...]:
    """What must fail verification even where the reference agrees: a NaN or Inf reaching an
    output, an integer overflow anywhere (IEC 61131-3: an error, not a wrap-around), and a NaN or
    Inf in the block's arithmetic on finite inputs (NaN inputs, a broken sensor, legitimately
    make the input guard compute NaN before it rejects the value)."""
    finite_inputs = all(np.isfinite(np.asarray(v, np.float64)).all() for v in inputs.values())
    problems = []
    for name, values in produced.items():
        if types[name] == "REAL" and (row := first_non_finite(values)) is not None:
            problems.append(f"output {name} is {np.float32(values[row])} at cycle {row} "
                            f"(line {int(table.lines[row])} of the data)")
    problems += [f"{block}:{f.pos[0]}:{f.pos[1]}: {label} ({f.detail}), {f.count} time(s) from cycle {f.first_cycle}"
                 for f, label in unsafe_findings(findings, finite_inputs)]
    return tuple(problems)


def replay_and_compare(replayer: Replayer, block: str, against: str, table: Table, time_column: str,
                        inputs: dict, expected: dict, quantisation: dict) -> Report:
    """Replay the block over `table` and compare every output bit for bit with `expected`; on the first
    mismatch replay again up to that cycle so the report shows the block's state where it diverged."""
    rows = table.rows
    start = time.perf_counter()
    machine = replayer.machine
    try:
        produced = replayer.replay(inputs, rows, outputs=tuple(expected))
    except BlockFailure as exc:
        return Report(block, against, Path(table.path).name, machine.cycle, tuple(expected), None,
                      tuple(replace(f) for f in machine.findings.values()), time.perf_counter() - start, quantisation,
                      engine=replayer.used, engine_note=replayer.note, failure=str(exc))
    seconds = time.perf_counter() - start
    findings = tuple(replace(f) for f in machine.findings.values())  # copies: the re-run below counts again
    types = {d.name: d.type.base for d in replayer.outputs}
    first = _first_mismatch(produced, {k: expected[k] for k in produced}, types)
    mismatch = None
    if first is not None:
        cycle, output = first
        machine.reset()
        machine.replay({name: np.asarray(col).tolist() for name, col in inputs.items()}, rows, outputs=(),
                       stop_after=cycle)
        want = expected[output][cycle]
        t = table.columns[time_column][cycle] if time_column in table.columns else float(cycle)
        got = produced[output][cycle]
        mismatch = Mismatch(cycle, table.lines[cycle], float(t), output, got.item() if hasattr(got, "item") else got,
                            want.item() if hasattr(want, "item") else want, machine.snapshot())
    return Report(block, against, Path(table.path).name, rows, tuple(produced), mismatch, findings, seconds,
                  quantisation, engine=replayer.used, engine_note=replayer.note,
                  unsafe=(*subnormal_declarations(machine.decls, block),
                          *_unsafe(produced, types, findings, table, block, inputs)), produced=produced)


def check_period(model: Model, table: Table) -> None:
    """The block's constants are discretised for the model's period: the data must be sampled at it."""
    if model.time_column not in table.columns or table.rows < 2:
        return
    dt = sample_period(table, model.time_column, f"{model.sample_period_s:g}")
    if abs(dt - model.sample_period_s) > SAMPLING_TOLERANCE * model.sample_period_s:
        raise UserError(f"{table.path}: column {model.time_column!r}: sampled every {dt:g} s, but the model was "
                        f"fitted for a call every {model.sample_period_s:g} s; give --resample {model.sample_period_s:g} to take "
                        f"the data onto it")


def block_limits(program: Program, source: str) -> Limits:
    """The safety limits the block was generated with, from its named constants."""
    constants = {d.name: d.initial for d in program.decls if d.section == "constant"}
    try:
        return limits_of_block(constants, source)
    except UserError:  # a limit it needs is missing: name those the block declares elsewhere
        limits = {name.upper() for name in LIMIT_NAMES.values()}
        elsewhere = [d.name for d in program.decls if d.section != "constant" and d.name.upper() in limits]
        if not elsewhere:
            raise
        raise UserError(f"{source}: {', '.join(elsewhere)} declared outside VAR CONSTANT (in PLCopen XML: localVars "
                        f"without constant=\"true\"); a safety limit must be a constant") from None


def compare_constants(program: Program, model: Model, limits: Limits) -> tuple[int, tuple[str, ...]]:
    """Every constant and read-only table the block declares, against the model's own values
    (contract/constants.py names them), and every coefficient of the model somewhere in the block.

    Replay proves behaviour on the data; table entries the data never reaches (a Bayes
    configuration never seen, an edge no sample lies next to) are only covered by this check.
    """
    # a constant, or any initialised declaration but an input's start value (the tables), is model data
    decls = {d.name: d for d in program.decls
             if d.section == "constant" or d.initial is not None and d.section != "input"}
    wanted, unknown, missing = expected(model, limits, list(decls))
    sections = {d.name.upper(): d.section for d in program.decls}
    read = names_read(program.body)
    errors, checked = [], 0
    for name in sorted(required(model)):
        section = sections.get(name.upper())
        if section is None:
            errors.append(f"{name}: missing from the block (every block this thermoplc writes for this model declares "
                          f"it: regenerate a block written by an older version)")
        elif section != "constant":
            errors.append(f"{name}: declared as {section}, but it is a constant of every block of this model")
        elif name.upper() not in read:  # a literal in its place computes with another value, or only seems to
            errors.append(f"{name}: declared but never read by the statements; every block of this model computes "
                          f"with it (was a use of it replaced by a literal?)")
    for name, values in wanted.items():
        decl = decls[name]
        found = decl.initial if isinstance(decl.initial, tuple) else (decl.initial,)
        bounds = decl.type.bounds
        if decl.section != "constant" and not name.upper().startswith(TABLE_PREFIX.upper()):
            errors.append(f"{name}: declared as {decl.section}, but the model's value is a constant")
            continue
        if len(found) != len(values) or bounds and bounds[1] - bounds[0] + 1 != len(values):
            errors.append(f"{name}: {len(found)} values in the block, the model has {len(values)}")
            continue
        for k, (got, want) in enumerate(zip(found, values)):
            checked += 1
            if isinstance(want, int) and not isinstance(want, bool):
                same = got == want and not isinstance(got, (bool, float))
            else:
                same = isinstance(got, float) and f32_bits(got) == f32_bits(want)
            if not same:
                where = f"{name}[{k}]" if len(values) > 1 or decl.type.bounds else name
                errors.append(f"{where}: block {_show(got)}, model {_show(want if isinstance(want, int) else float(want))} "
                              f"({ulp_distance(got, want) if isinstance(got, float) else '?'} ULP)")
    # a constant the model does not have is a computation it does not have (a filter gain, an extra
    # term), which data may not reach: the block is not the model's
    errors += [f"{name}: declared in the block, but the model has no such constant"
               + ("" if decls[name].section == "constant" else " or table") for name in unknown]
    if missing:
        shown = ", ".join(constant_name(k) for k in missing[:5]) + (f" and {len(missing) - 5} more" if len(missing) > 5 else "")
        errors.append(f"{shown}: missing from the block (no constant or table holds these coefficients of the model; "
                      f"a model file with coefficients its kind does not use is refused by generate)")
    return checked, tuple(errors)


def verify_against_model(block: str, model: Model, model_path: str, table: Table,
                         overrides: dict | None = None, engine: str = "auto", probe_every: int | None = None) -> Report:
    program, machine = load_block(block, engine)
    limits = block_limits(program, block)
    check_period(model, table)
    seen = model_expectation(block, program, machine, limits, model, model_path, table, overrides, probe_every)
    inputs, control, probing, block32 = seen.inputs, seen.control, seen.probing, seen.expected
    ideal = block_outputs(model, {**inputs, **reference_keys(probing)}, "f64", limits, control_of(control))
    quantisation = {model.target.name: float(np.max(np.abs(block32[model.target.name].astype(np.float64)
                                                          - ideal[model.target.name])))}
    against = f"the float32 reference of {Path(model_path).name} ({model.kind})"
    report = replay_and_compare(machine, block, against, table, model.time_column, {**inputs, **control, **probing},
                                block32, quantisation)
    checked, errors = compare_constants(program, model, limits)
    errors = (*errors, *(start_value_errors(machine.inputs) if model.probe is not None else ()))
    said = [line for line in (control_summary(control, table.rows), probing_summary(probing)) if line]
    fused = contraction(program, block, seen.columns, block32, table.rows) if report.ok else None
    return replace(report, constants_checked=checked, constant_errors=errors, limits=limits, control="; ".join(said),
                   contraction=fused)


def other_model(block: str, model: Model, model_path: str) -> str:
    """Said first when the block's header names another model than `model` (its fingerprint line, as generate
    writes it): the likeliest cause of every difference that follows; empty when it names this one or none."""
    try:
        text = Path(block).read_text("utf-8", errors="replace")
    except OSError:
        return ""
    stated = re.search(r"\bModel \S+, fingerprint ([0-9a-f]{16})\b", text)  # '//', '(*' or PLCopen XML's text
    if stated is None or stated.group(1) == model.fingerprint():
        return ""
    return (f"{Path(block).name} was generated from another model (fingerprint {stated.group(1)} in its header) "
            f"than {Path(model_path).name} (fingerprint {model.fingerprint()}): verify it against the model file it "
            f"was generated from, or generate it again from this one")


def _numbered_fault(output: str, column: str, declared: list[str]) -> str:
    """For a trace recorded on a block generated before fault bits were named after their sensors
    (Fault_2): the bit of this block that is the same output (the fault bits are declared in the
    inputs' order), as an --expect mapping; else nothing."""
    stem, _, number = output.partition("_")
    bits = [name for name in declared if name.upper().startswith(FAULT_PREFIX.upper())]
    if f"{stem}_".upper() != FAULT_PREFIX.upper() or not number.isdigit() or not 1 <= int(number) <= len(bits):
        return ""
    bit = bits[int(number) - 1]
    return (f" (this block names its fault bits after their sensors; {output} of a block generated before that is "
            f"{bit} here: --expect {bit}={column})")


def verify_against_trace(block: str, table: Table, expect: dict, overrides: dict | None = None,
                         time_column: str = "time_s", engine: str = "auto") -> Report:
    """expect maps block output names to trace columns holding what the PLC produced."""
    _, machine = load_block(block, engine)
    inputs = block_columns(machine.inputs, table, overrides, block)
    outputs = {d.name: d for d in machine.outputs}
    expected = {}
    for output, column in expect.items():
        if output not in outputs:
            raise UserError(f"{block}: no output {output!r} to compare with column {column!r}; outputs are {', '.join(outputs)}"
                            + _numbered_fault(output, column, list(outputs)))
        expected[output] = cells_as(table, column, outputs[output].type.base, f"the recorded output {output}")
    report = replay_and_compare(machine, block, f"the recorded outputs ({', '.join(expect.values())})", table,
                                 time_column, inputs, expected, {})
    notes = [unread_control_columns(table, machine.inputs)]
    if report.mismatch is not None and isinstance(report.mismatch.expected_value, float):
        notes.append("a trace must hold every REAL to 9 significant digits (or as hex): exported with fewer, a value "
                     "differs by its rounding alone")
    return replace(report, control="; ".join(note for note in notes if note))
