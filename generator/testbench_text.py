"""A BenchPlan (generator/testbench.py) as source text of one dialect: the data blocks (Siemens) or
constant arrays (IEC) and the bench function block. One statement shape for every dialect; what
differs is spelt by _Spelling."""
from __future__ import annotations

from dataclasses import dataclass

from thermoplc.generator.ir import GenerationError
from thermoplc.generator.literals import real_literal
from thermoplc.generator.printer import safe_comment, safe_string
from thermoplc.generator.testbench import MAX_CALLS, TARGETS, BenchPlan, Chunk, bench_names, check_plan, chunks

VALUES_PER_LINE = 8


@dataclass(frozen=True)
class _Spelling:
    local: str  # '#' before a local name (TIA)
    types: dict
    array: str
    comment: str  # a line comment's opening and closing
    data_blocks: bool  # the rows in global data blocks (Siemens) or in the bench's constant arrays (IEC)


SPELLINGS = {
    "tia": _Spelling("#", {"REAL": "Real", "BOOL": "Bool", "INT": "Int"}, "Array[{lo}..{hi}] of {type}", "// {}", True),
    "step7": _Spelling("", {"REAL": "REAL", "BOOL": "BOOL", "INT": "INT"}, "ARRAY[{lo}..{hi}] OF {type}", "// {}", True),
    "iec": _Spelling("", {"REAL": "REAL", "BOOL": "BOOL", "INT": "INT"}, "ARRAY[{lo}..{hi}] OF {type}", "(* {} *)",
                     False),
}


def _literal(value, kind: str) -> str:
    if kind == "REAL":
        return real_literal(float(value))
    if kind == "BOOL":
        return "TRUE" if value else "FALSE"
    return str(int(value))


class _Text:
    def __init__(self, plan: BenchPlan, dialect: str):
        self.plan, self.dialect, self.sp = plan, dialect, SPELLINGS[dialect]
        self.name, self.db_prefix = bench_names(plan.block)
        self.chunks = chunks(plan, dialect)
        self.reals = [k for k, p in enumerate(plan.outputs) if p.type == "REAL"]

    def n(self, name: str) -> str:
        return self.sp.local + name

    def comment(self, text: str) -> str:
        return self.sp.comment.format(safe_comment(text))

    def array(self, lo: int, hi: int, kind: str) -> str:
        return self.sp.array.format(lo=lo, hi=hi, type=self.sp.types[kind])

    def data_ref(self, chunk: Chunk, array: str) -> str:
        if self.sp.data_blocks:
            return f'"{self.db_prefix}{chunk.number}".{array}[{self.n("Row")}]'
        return f"D{chunk.number}_{array}[Row]"

    def arrays(self):
        """(array name, port) of every column the bench holds: I1.. the inputs, E1.. the expected outputs."""
        return [*((f"I{k + 1}", p) for k, p in enumerate(self.plan.inputs)),
                *((f"E{k + 1}", p) for k, p in enumerate(self.plan.outputs))]

    # -- data -------------------------------------------------------------------------------------
    def data_block(self, chunk: Chunk) -> list[str]:
        tia = self.dialect == "tia"
        lines = [f'DATA_BLOCK "{self.db_prefix}{chunk.number}"',
                 f"TITLE = '{safe_string(f'Test bench data of {self.plan.block}: calls {chunk.first + 1} to {chunk.first + chunk.rows}')}'"]
        lines += ["{ S7_Optimized_Access := 'TRUE' }", "VERSION : 0.1", "   VAR"] if tia else \
            ["VERSION : '0.1'", "AUTHOR : thermopl", "   STRUCT"]
        for array, port in self.arrays():
            lines.append(f"      {array} : {self.array(0, chunk.rows - 1, port.type)};   {self.comment(port.name)}")
        lines += ["   END_VAR" if tia else "   END_STRUCT;", "BEGIN"]
        for array, port in self.arrays():
            values = port.values[chunk.first:chunk.first + chunk.rows]
            lines += [f"   {array}[{k}] := {_literal(v, port.type)};" for k, v in enumerate(values)]
        return lines + ["END_DATA_BLOCK", ""]

    def constant_arrays(self) -> list[str]:
        lines = []
        for chunk in self.chunks:
            for array, port in self.arrays():
                values = [_literal(v, port.type) for v in port.values[chunk.first:chunk.first + chunk.rows]]
                rows = [", ".join(values[i:i + VALUES_PER_LINE]) for i in range(0, len(values), VALUES_PER_LINE)]
                lines.append(f"    D{chunk.number}_{array} : {self.array(0, chunk.rows - 1, port.type)} := ["
                             + ",\n        ".join(rows) + f"]; {self.comment(f'{port.name}, calls {chunk.first + 1} to {chunk.first + chunk.rows}')}")
        return lines

    # -- declarations ---------------------------------------------------------------------------------
    def declarations(self) -> list[str]:
        t, plan = self.sp.types, self.plan
        indent = "      " if self.dialect == "tia" else "    "
        end = "   END_VAR" if self.dialect == "tia" else "END_VAR"

        def section(keyword, decls):
            head = f"   {keyword}" if self.dialect == "tia" else keyword
            return [head, *(f"{indent}{name} : {kind};{f'   {self.comment(c)}' if c else ''}" for name, kind, c in decls),
                    end]
        reals = max(1, len(self.reals))
        lines = section("VAR_INPUT", [("Restart", t["BOOL"], "TRUE: start again from call 1 (the block is Reset at call 1)")])
        lines += section("VAR_OUTPUT", [
            ("Done", t["BOOL"], f"TRUE once all {plan.calls} calls are made"),
            ("Calls", t["INT"], "calls of the block made"),
            ("Mismatches", t["INT"], f"calls with an output not as expected (counted up to {MAX_CALLS})"),
            ("FirstMismatchCall", t["INT"], "the first such call, counted from 1 (0: none)"),
            ("FirstMismatchOutput", t["INT"], "its first differing output, numbered as listed in the header"),
            ("FirstExpected", t["REAL"], "that output's expected value (BOOL as 0.0 or 1.0)"),
            ("FirstActual", t["REAL"], "and the block's"),
            ("MaxDiff", self.array(1, reals, "REAL"), "largest |block - expected| of each REAL output, its unit"),
        ])
        block_type = f'"{plan.block}"' if self.sp.data_blocks else plan.block
        lines += section("VAR", [("Dut", block_type, "the block under test")])
        temps = [("Step", t["INT"], ""), ("Row", t["INT"], ""), ("Differs", t["BOOL"], ""), ("Diff", t["REAL"], "")]
        temps += [(array, t[port.type], port.name) for array, port in self.arrays()]
        lines += section("VAR_TEMP", temps)
        constants = [("CallCount", "INT", str(plan.calls)), ("RowsPerCycle", "INT", str(plan.rows_per_cycle))]
        if plan.tolerance:
            constants.append(("Tolerance", "REAL", real_literal(plan.tolerance)))
        if self.dialect == "step7":
            lines += ["CONST", *(f"    {name} := {value};" for name, _, value in constants), "END_CONST"]
        else:
            data = [] if self.sp.data_blocks else self.constant_arrays()
            decls = [f"{indent}{name} : {t[kind]} := {value};" for name, kind, value in constants]
            lines += ["   VAR CONSTANT" if self.dialect == "tia" else "VAR CONSTANT", *decls, *data, end]
        return lines

    # -- body ----------------------------------------------------------------------------------------
    def body(self) -> list[str]:
        n, plan = self.n, self.plan
        out = [f"IF {n('Restart')} THEN",
               *(f"    {n(v)} := 0;" for v in ("Calls", "Mismatches", "FirstMismatchCall", "FirstMismatchOutput")),
               f"    {n('FirstExpected')} := 0.0;", f"    {n('FirstActual')} := 0.0;",
               f"    FOR {n('Step')} := 1 TO {max(1, len(self.reals))} DO",
               f"        {n('MaxDiff')}[{n('Step')}] := 0.0;", "    END_FOR;", "END_IF;",
               f"FOR {n('Step')} := 1 TO {n('RowsPerCycle')} DO",
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
        arguments = ", ".join(f"{p.name} := {n(f'I{k + 1}')}" for k, p in enumerate(plan.inputs))
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
        actual, expected = f"{n('Dut')}.{port.name}", n(f"E{k + 1}")
        first = [f"                {n('FirstMismatchOutput')} := {k + 1};"]
        if port.type == "REAL":
            slot = f"{n('MaxDiff')}[{self.reals.index(k) + 1}]"
            lines = [f"        {n('Diff')} := ABS({actual} - {expected});",
                     f"        IF {n('Diff')} > {slot} THEN", f"            {slot} := {n('Diff')};", "        END_IF;"]
            differs = f"{actual} <> {expected}"
            if self.plan.tolerance:  # NOT (<=): a NaN difference is a mismatch
                differs += f" AND NOT ({n('Diff')} <= {n('Tolerance')})"
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
    def source(self) -> str:
        plan = self.plan
        header = [*plan.notes, "Outputs compared, numbered as FirstMismatchOutput counts them:",
                  *(f"  {k + 1}: {p.name} ({p.type})" for k, p in enumerate(plan.outputs))]
        lines = [line for chunk in self.chunks for line in self.data_block(chunk)] if self.sp.data_blocks else []
        title = safe_string(f"Test bench of {plan.block}: {plan.calls} recorded calls, every output compared")
        if self.dialect == "tia":
            lines += [f'FUNCTION_BLOCK "{self.name}"', f"TITLE = {title}", "{ S7_Optimized_Access := 'TRUE' }",
                      "AUTHOR : thermopl", "FAMILY : ThermTB", f"NAME : {self.name[:8]}", "VERSION : 0.1"]
        elif self.dialect == "step7":
            lines += [f'FUNCTION_BLOCK "{self.name}"', f"TITLE = '{title}'", "VERSION : '0.1'", "AUTHOR : thermopl",
                      f"NAME : {self.name[:8]}", "FAMILY : ThermTB"]
        else:
            lines += [f"FUNCTION_BLOCK {self.name}", self.comment(title)]
        lines += [self.comment(line) for line in header]
        lines += self.declarations()
        if self.sp.data_blocks:
            lines.append("BEGIN")
        lines += self.body()
        lines.append("END_FUNCTION_BLOCK")
        return "\n".join(lines) + "\n"


def render_bench(plan: BenchPlan, dialect: str) -> str:
    """The test bench's source in `dialect` (tia, step7, iec), byte-identical for the same plan."""
    if dialect not in TARGETS:
        raise GenerationError(f"dialect {dialect!r}: a test bench is written for {', '.join(TARGETS)}")
    check_plan(plan)
    return _Text(plan, dialect).source()
