"""A test bench run in thermoplc's interpreter: the bench's function block with the block under test as
an instance it calls and the data blocks it reads, every REAL operation rounded to binary32 as in
verifier/engines/interpreter.py. Its counters are what the PLC would show."""
from __future__ import annotations

from dataclasses import dataclass

from thermoplc.base.binary32 import INT_RANGES
from thermoplc.base.errors import UserError
from thermoplc.verifier.reading import syntax as s
from thermoplc.verifier.engines.interpreter import Machine

COUNTERS = ("Done", "Calls", "Mismatches", "FirstMismatchCall", "FirstMismatchOutput", "FirstExpected", "FirstActual",
            "MaxDiff")


@dataclass(frozen=True)
class BenchCounters:
    """The bench's outputs after its last PLC cycle, and how many cycles it took."""
    done: bool
    calls: int
    mismatches: int
    first_mismatch_call: int
    first_mismatch_output: int
    first_expected: float
    first_actual: float
    max_diff: tuple[float, ...]
    cycles: int


def data_arrays(data_blocks: tuple[s.DataBlock, ...], source: str) -> dict:
    """Data block name (upper case) -> array name (upper case) -> (declaration, values), the values its
    BEGIN section gives, zero (FALSE) elsewhere; a value the array cannot hold is an error."""
    found = {}
    for db in data_blocks:
        arrays = {}
        for d in db.decls:
            if not d.type.bounds or d.type.base == "BLOCK":
                raise UserError(f"{source}:{d.pos[0]}:{d.pos[1]}: {d.name}: a test bench's data block holds arrays "
                                f"of REAL, BOOL or INT")
            lo, hi = d.type.bounds
            zero = 0.0 if d.type.base == "REAL" else False if d.type.base == "BOOL" else 0
            arrays[d.name.upper()] = (d, [zero] * (hi - lo + 1))
        for name, index, value in db.values:
            if name.upper() not in arrays:
                raise UserError(f"{source}: DATA_BLOCK {db.name}: {name} is not declared in it")
            d, values = arrays[name.upper()]
            lo, hi = d.type.bounds
            if not lo <= index <= hi:
                raise UserError(f"{source}: DATA_BLOCK {db.name}: {name}[{index}] outside {name}[{lo}..{hi}]")
            kind = "BOOL" if isinstance(value, bool) else "INT" if isinstance(value, int) else "REAL"
            if kind != d.type.base and not (kind == "INT" and d.type.base in INT_RANGES):
                raise UserError(f"{source}: DATA_BLOCK {db.name}: {name}[{index}] := {value!r} in an array of "
                                f"{d.type.base}")
            values[index - lo] = value
        if db.name.upper() in found:
            raise UserError(f"{source}: DATA_BLOCK {db.name} is declared twice")
        found[db.name.upper()] = arrays
    return found


class BenchMachine(Machine):
    """A function block that may call instances of other blocks and read data blocks (a test bench)."""

    def __init__(self, program: s.Program, source: str, blocks: dict[str, tuple[s.Program, str]], data: dict):
        self.blocks = {name.upper(): block for name, block in blocks.items()}
        self.data = data
        super().__init__(program, source)

    def _block_of(self, d: s.VarDecl) -> tuple[s.Program, str]:
        """The block (and its file) an instance declaration names, or an error naming the blocks given."""
        if d.type.block.upper() not in self.blocks:
            self._fail(d.pos, f"{d.name} is an instance of {d.type.block}, a block not given "
                              f"(given: {', '.join(p.name for p, _ in self.blocks.values())})")
        return self.blocks[d.type.block.upper()]

    def _initial(self, d: s.VarDecl):
        if d.type.base != "BLOCK":
            return super()._initial(d)
        return Machine(*self._block_of(d))

    def _instance(self, name: str, pos: s.Pos) -> tuple[int, s.Program]:
        decl = self._decl(name, pos)
        if decl.type.base != "BLOCK":
            self._fail(pos, f"{decl.name} is not an instance of a block")
        return self.slots[decl.name.upper()], self._block_of(decl)[0]

    def _stmt(self, st):
        if not isinstance(st, s.BlockCall):
            return super()._stmt(st)
        slot, program = self._instance(st.instance, st.pos)
        inputs = {d.name.upper(): d for d in program.decls if d.section == "input"}
        arguments = []
        for name, expr in st.arguments:
            d = inputs.get(name.upper())
            if d is None:
                self._fail(st.pos, f"{name} is not an input of {program.name}")
            fn, kind = self._expr(expr)
            if (kind == "REAL") != (d.type.base == "REAL") or (kind == "BOOL") != (d.type.base == "BOOL"):
                self._fail(expr.pos, f"{name} of {program.name} is {d.type.base}; given a {kind} value")
            arguments.append((d.name, fn))

        def call_block(v):
            v[slot].call({name: fn(v) for name, fn in arguments})
        return call_block

    def _expr(self, e):
        if isinstance(e, s.Member):
            slot, program = self._instance(e.instance, e.pos)
            outputs = {d.name.upper(): d for d in program.decls if d.section == "output"}
            d = outputs.get(e.name.upper())
            if d is None or d.type.bounds:
                self._fail(e.pos, f"{e.name} is not a scalar output of {program.name}")
            key = d.name.upper()
            return (lambda v: v[slot].values[v[slot].slots[key]]), d.type.base
        if isinstance(e, s.GlobalItem):
            return self._global_item(e)
        if isinstance(e, s.Name) and self._decl(e.name, e.pos).type.base == "BLOCK":
            self._fail(e.pos, f"the instance {e.name} is used as a value")
        return super()._expr(e)

    def _global_item(self, e: s.GlobalItem):
        arrays = self.data.get(e.block.upper())
        if arrays is None or e.name.upper() not in arrays:
            self._fail(e.pos, f"no array {e.name} in a data block {e.block}")
        d, values = arrays[e.name.upper()]
        lo, hi = d.type.bounds
        index = self._int_expr(e.index)
        failure = self._failure

        def read_item(v):
            i = index(v)
            if not lo <= i <= hi:
                failure(e.pos, f"index {i} outside {e.block}.{d.name}[{lo}..{hi}] at cycle {self.cycle}")
            return values[i - lo]
        return read_item, d.type.base


def run_bench(bench: s.Program, source: str, blocks: dict[str, tuple[s.Program, str]], data: dict,
              max_cycles: int) -> BenchCounters:
    """Call the bench once per PLC cycle, as a cyclic task would, until it says Done (or `max_cycles`)."""
    machine = BenchMachine(bench, source, blocks, data)
    cycles = 0
    while cycles < max_cycles:
        machine.call({})
        cycles += 1
        if machine.values[machine.slots["DONE"]]:
            break
    got = {name: machine.values[machine.slots[name.upper()]] for name in COUNTERS}
    return BenchCounters(bool(got["Done"]), got["Calls"], got["Mismatches"], got["FirstMismatchCall"],
                         got["FirstMismatchOutput"], got["FirstExpected"], got["FirstActual"], tuple(got["MaxDiff"]),
                         cycles)
