"""A BenchPlan (generator/testbench.py) as source text of one dialect: the data blocks (Siemens) or
constant arrays (IEC) and the bench function block. One statement shape for every dialect; what
differs is spelt by each dialect's BenchSpelling (generator/dialects/)."""
from __future__ import annotations

from dataclasses import dataclass

from thermoplc.generator.dialects import plcopen_wrapped, registry
from thermoplc.generator.ir import GenerationError
from thermoplc.generator.literals import real_literal
from thermoplc.generator.printer import UNDATED, plcopen_pou, plcopen_type, safe_comment, safe_string
from thermoplc.generator.testbench import MAX_CALLS, TARGETS, BenchPlan, Chunk, bench_names, check_plan, chunks

VALUES_PER_LINE = 8


@dataclass(frozen=True)
class _Decl:
    """A variable of the bench: its type, its start value's text (a tuple for an array), what it holds."""
    name: str
    type: str  # REAL, BOOL, INT, or BLOCK (an instance of `block`)
    bounds: tuple[int, int] | None = None
    block: str = ""
    initial: str | tuple | None = None
    comment: str = ""


SPELLINGS = {name: record.bench_spelling for name, record in registry().items()}


def _literal(value, kind: str) -> str:
    if kind == "REAL":
        return real_literal(float(value))
    if kind == "BOOL":
        return "TRUE" if value else "FALSE"
    return str(int(value))


class _Text:
    def __init__(self, plan: BenchPlan, dialect: str):
        self.plan, self.dialect, self.sp = plan, dialect, SPELLINGS[dialect]
        self.local, self.types = registry()[dialect].local_prefix, registry()[dialect].type_names  # the block's own
        self.name, self.db_prefix = bench_names(plan.block)
        self.chunks = chunks(plan, dialect)
        self.reals = [k for k, p in enumerate(plan.outputs) if p.type == "REAL"]

    def n(self, name: str) -> str:
        return self.local + name

    def comment(self, text: str) -> str:
        return self.sp.comment.format(safe_comment(text))

    def spelt(self, lines: tuple[str, ...], title: str) -> list[str]:
        """A dialect's lines of a header, with the bench's name and this title put in."""
        return [line.format(name=self.name, short=self.name[:8], title=title, title_comment=self.comment(title))
                for line in lines]

    def array(self, lo: int, hi: int, kind: str) -> str:
        return self.sp.array.format(lo=lo, hi=hi, type=self.types[kind])

    def data_ref(self, chunk: Chunk, array: str) -> str:
        if self.sp.data_blocks:
            return f'"{self.db_prefix}{chunk.number}".{array}[{self.n("Row")}]'
        return f"D{chunk.number}_{array}[Row]"

    def arrays(self):
        """(array name, port) of every column the bench holds: In1.. the inputs, Exp1.. the expected outputs
        (short names: I1 and E1 read as input addresses in SCL)."""
        return [*((f"In{k + 1}", p) for k, p in enumerate(self.plan.inputs)),
                *((f"Exp{k + 1}", p) for k, p in enumerate(self.plan.outputs))]

    # -- data -------------------------------------------------------------------------------------
    def data_block(self, chunk: Chunk) -> list[str]:
        title = safe_string(f"Test bench data of {self.plan.block}: calls {chunk.first + 1} to {chunk.first + chunk.rows}")
        lines = [f'DATA_BLOCK "{self.db_prefix}{chunk.number}"', *self.spelt(self.sp.data_block_head, title)]
        for array, port in self.arrays():
            lines.append(f"      {array} : {self.array(0, chunk.rows - 1, port.type)};   {self.comment(port.name)}")
        lines += [self.sp.data_block_end, "BEGIN"]
        for array, port in self.arrays():
            values = port.values[chunk.first:chunk.first + chunk.rows]
            lines += [f"   {array}[{k}] := {_literal(v, port.type)};" for k, v in enumerate(values)]
        return lines + ["END_DATA_BLOCK", ""]

    # -- declarations ---------------------------------------------------------------------------------
    def sections(self) -> list[tuple[str, list[_Decl]]]:
        """The bench's variables by section, in no dialect's spelling."""
        plan = self.plan
        constants = [_Decl("CallCount", "INT", initial=str(plan.calls)),
                     _Decl("RowsPerCycle", "INT", initial=str(plan.rows_per_cycle))]
        constants += [_Decl(f"Tol{k + 1}", "REAL", initial=real_literal(port.tolerance),
                            comment=f"{port.name} passes within this of the expected value")
                      for k, port in enumerate(plan.outputs) if port.tolerance]
        if not self.sp.data_blocks:
            constants += [_Decl(f"D{chunk.number}_{array}", port.type, (0, chunk.rows - 1),
                                initial=tuple(_literal(v, port.type) for v in port.values[chunk.first:chunk.first + chunk.rows]),
                                comment=f"{port.name}, calls {chunk.first + 1} to {chunk.first + chunk.rows}")
                          for chunk in self.chunks for array, port in self.arrays()]
        return [
            ("VAR_OUTPUT", [
                _Decl("Done", "BOOL", comment=f"TRUE once all {plan.calls} calls are made"),
                _Decl("Calls", "INT", comment="calls of the block made"),
                _Decl("Mismatches", "INT", comment=f"calls with an output not as expected (counted up to {MAX_CALLS})"),
                _Decl("FirstMismatchCall", "INT", comment="the first such call, counted from 1 (0: none)"),
                _Decl("FirstMismatchOutput", "INT", comment="its first differing output, numbered as the header lists them"),
                _Decl("FirstExpected", "REAL", comment="that output's expected value (BOOL as 0.0 or 1.0)"),
                _Decl("FirstActual", "REAL", comment="and the block's"),
                _Decl("MaxDiff", "REAL", (1, max(1, len(self.reals))),
                      comment="largest |block - expected| of each REAL output, in its unit")]),
            ("VAR", [_Decl("Dut", "BLOCK", block=plan.block, comment="the block under test")]),
            ("VAR_TEMP", [_Decl("Pass", "INT"), _Decl("Row", "INT"), _Decl("Differs", "BOOL"), _Decl("Diff", "REAL"),
                          *(_Decl(array, port.type, comment=port.name) for array, port in self.arrays())]),
            ("VAR CONSTANT", constants),
        ]

    def st_type(self, d: _Decl) -> str:
        if d.block:
            return f'"{d.block}"' if self.sp.data_blocks else d.block
        return self.array(*d.bounds, d.type) if d.bounds else self.types[d.type]

    def declarations(self) -> list[str]:
        indent, lines = self.sp.declaration_indent, []
        for keyword, decls in self.sections():
            if keyword == "VAR CONSTANT" and self.sp.untyped_constants:
                lines += ["CONST", *(f"    {d.name} := {d.initial};" for d in decls), "END_CONST"]
                continue
            lines.append(f"{self.sp.section_indent}{keyword}")
            for d in decls:
                initial = ""
                if isinstance(d.initial, tuple):
                    rows = [", ".join(d.initial[i:i + VALUES_PER_LINE]) for i in range(0, len(d.initial), VALUES_PER_LINE)]
                    initial = " := [" + f",\n{indent}    ".join(rows) + "]"
                elif d.initial is not None:
                    initial = f" := {d.initial}"
                note = f"   {self.comment(d.comment)}" if d.comment else ""
                lines.append(f"{indent}{d.name} : {self.st_type(d)}{initial};{note}")
            lines.append(f"{self.sp.section_indent}END_VAR")
        return lines

    # -- body ----------------------------------------------------------------------------------------
    def body(self) -> list[str]:
        n, plan = self.n, self.plan
        out = [f"FOR {n('Pass')} := 1 TO {n('RowsPerCycle')} DO",
               f"    IF {n('Calls')} < {n('CallCount')} THEN"]
        many = len(self.chunks) > 1
        pad = " " * (12 if many else 8)
        for k, chunk in enumerate(self.chunks):
            if many:
                last = chunk.first + chunk.rows
                out.append("        ELSE" if k == len(self.chunks) - 1 else
                           f"        {'ELSIF' if k else 'IF'} {n('Calls')} < {last} THEN")
            row = f"{n('Calls')} - {chunk.first}" if chunk.first else n("Calls")
            out += [f"{pad}{n('Row')} := {row};",
                    *(f"{pad}{n(array)} := {self.data_ref(chunk, array)};" for array, _ in self.arrays())]
        if many:
            out.append("        END_IF;")
        arguments = ", ".join(f"{p.name} := {n(f'In{k + 1}')}" for k, p in enumerate(plan.inputs))
        out += [f"        {n('Dut')}({arguments});", f"        {n('Differs')} := FALSE;"]
        for k, port in enumerate(plan.outputs):
            out += self.compare(k, port)
        out += [f"        IF {n('Differs')} THEN",
                f"            IF {n('Mismatches')} = 0 THEN",
                f"                {n('FirstMismatchCall')} := {n('Calls')} + 1;", "            END_IF;",
                f"            IF {n('Mismatches')} < {MAX_CALLS} THEN",
                f"                {n('Mismatches')} := {n('Mismatches')} + 1;", "            END_IF;", "        END_IF;",
                f"        {n('Calls')} := {n('Calls')} + 1;", "    END_IF;", "END_FOR;",
                f"{n('Done')} := {n('Calls')} >= {n('CallCount')};"]
        return out

    def compare(self, k: int, port) -> list[str]:
        n = self.n
        actual, expected = f"{n('Dut')}.{port.name}", n(f"Exp{k + 1}")
        first = [f"                {n('FirstMismatchOutput')} := {k + 1};"]
        if port.type == "REAL":
            slot = f"{n('MaxDiff')}[{self.reals.index(k) + 1}]"
            lines = [f"        {n('Diff')} := ABS({actual} - {expected});",
                     f"        IF {n('Diff')} > {slot} THEN", f"            {slot} := {n('Diff')};", "        END_IF;"]
            differs = f"{actual} <> {expected}"
            if port.tolerance:  # NOT (<=): a NaN difference is a mismatch
                differs += f" AND NOT ({n('Diff')} <= {n(f'Tol{k + 1}')})"
            first += [f"                {n('FirstExpected')} := {expected};", f"                {n('FirstActual')} := {actual};"]
        elif port.type == "BOOL":
            lines, differs = [], f"{actual} XOR {expected}"
            first += [f"                {n('FirstExpected')} := 0.0;", f"                {n('FirstActual')} := 0.0;",
                      f"                IF {expected} THEN", f"                    {n('FirstExpected')} := 1.0;",
                      "                ELSE", f"                    {n('FirstActual')} := 1.0;", "                END_IF;"]
        else:
            lines, differs = [], f"{actual} <> {expected}"
            first += [f"                {n('FirstExpected')} := INT_TO_REAL({expected});",
                      f"                {n('FirstActual')} := INT_TO_REAL({actual});"]
        return lines + [f"        IF {differs} THEN", f"            IF NOT {n('Differs')} AND {n('Mismatches')} = 0 THEN",
                         *first, "            END_IF;", f"            {n('Differs')} := TRUE;", "        END_IF;"]

    # -- the file -----------------------------------------------------------------------------------
    def title(self) -> str:
        return safe_string(f"Test bench of {self.plan.block}: {self.plan.calls} recorded calls, every output compared")

    def header(self) -> list[str]:
        return [*self.plan.notes, "Outputs compared, numbered as FirstMismatchOutput counts them:",
                *(f"  {k + 1}: {p.name} ({p.type})" for k, p in enumerate(self.plan.outputs))]

    def source(self) -> str:
        header, title = self.header(), self.title()
        lines = [line for chunk in self.chunks for line in self.data_block(chunk)] if self.sp.data_blocks else []
        lines += self.spelt(self.sp.block_head, title)
        lines += [self.comment(line) for line in header]
        lines += self.declarations()
        if self.sp.data_blocks:
            lines.append("BEGIN")
        lines += self.body()
        lines.append("END_FUNCTION_BLOCK")
        return "\n".join(lines) + "\n"


_PLCOPEN_SECTIONS = {"VAR_INPUT": ("inputVars", ""), "VAR_OUTPUT": ("outputVars", ""), "VAR": ("localVars", ""),
                     "VAR_TEMP": ("tempVars", ""), "VAR CONSTANT": ("localVars", ' constant="true"')}


def _plcopen(text: _Text, version: str) -> str:
    """The iec bench as PLCopen TC6 XML: one POU, its data as constant arrays (CODESYS, TwinCAT import)."""
    def variable(d: _Decl) -> dict:
        return {"name": d.name, "type_xml": plcopen_type(d.type, d.bounds, d.block), "comment": safe_comment(d.comment),
                "simple": d.initial if isinstance(d.initial, str) else None,
                "array": list(d.initial) if isinstance(d.initial, tuple) else []}
    sections = [(*_PLCOPEN_SECTIONS[keyword], [variable(d) for d in decls]) for keyword, decls in text.sections()]
    return plcopen_pou(text.name, version, text.title(), UNDATED, [safe_comment(line) for line in text.header()],
                       sections, text.body())


def render_bench(plan: BenchPlan, dialect: str, plcopen: bool = False, version: str = "") -> str:
    """The test bench's source in `dialect` (tia, step7, iec; PLCopen XML around iec with `plcopen`),
    byte-identical for the same plan."""
    if dialect not in TARGETS:
        raise GenerationError(f"dialect {dialect!r}: a test bench is written for {', '.join(TARGETS)}")
    if plcopen and not registry()[dialect].plcopen:
        raise GenerationError(f"PLCopen XML holds the {plcopen_wrapped().name} dialect")
    check_plan(plan)
    text = _Text(plan, dialect)
    return _plcopen(text, version) if plcopen else text.source()
