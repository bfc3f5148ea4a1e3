"""Reference semantics of the emitted ST: every REAL operation rounded to binary32.

The AST is compiled once into Python closures over a list of variable slots; a call runs the
closures. REAL values are Python floats that always hold binary32 values: an operation is done
in binary64 and rounded to binary32, which is exact for + - * / and SQRT (53 >= 2*24+2).
"""
from __future__ import annotations

import math
from array import array

import numpy as np

from thermoplc.base.binary32 import FLT_MAX, FLT_MIN_NORMAL, INT_RANGES
from thermoplc.verifier.reading import syntax as s
from thermoplc.verifier.engines.semantics import (CONVERSIONS, MAX_LOOP_ITERATIONS, MAX_REPLAY_LOOP_ITERATIONS,
                                          NON_PORTABLE_FUNCTIONS, PORTABLE_REAL_FUNCTIONS, UNSET, BlockFailure, Finding,
                                          InterpretError, int_result_kind, literal_kind)

class Machine:
    """One function-block instance: its memory persists between calls, VAR_TEMP does not."""

    def __init__(self, program: s.Program, source: str = "<block>"):
        self.program = program
        self.source = source
        self.cycle = 0
        self.findings: dict[tuple, Finding] = {}
        self._loop_cycle, self._loop_count, self._loop_total = -1, 0, 0
        self._cell = array("f", [0.0])
        self.slots: dict[str, int] = {}
        self.decls: list[s.VarDecl] = []
        for d in program.decls:
            key = d.name.upper()
            if key in self.slots:
                self._fail(d.pos, f"{d.name} is declared twice (names ignore case)")
            self._check_initial(d)
            self.slots[key] = len(self.decls)
            self.decls.append(d)
        self.inputs = [d for d in self.decls if d.section == "input"]
        self.outputs = [d for d in self.decls if d.section == "output"]
        self.temp_slots = [self.slots[d.name.upper()] for d in self.decls if d.section == "temp"]
        self.per_call_slots = [self.slots[name.upper()] for name in program.per_call]
        self.body = self._block(program.body)
        self.values: list = []
        self.reset()

    def _check_initial(self, d: s.VarDecl) -> None:
        """A start value the declared type cannot hold is an error: engines would read it differently."""
        values = d.initial if isinstance(d.initial, tuple) else () if d.initial is None else (d.initial,)
        base = d.type.base
        for value in values:
            if base == "BOOL" and not isinstance(value, bool):
                self._fail(d.pos, f"{d.name} is BOOL but starts at {value!r}; expected TRUE or FALSE")
            if base in INT_RANGES and (isinstance(value, bool) or not isinstance(value, int)
                                       or not INT_RANGES[base][0] <= value <= INT_RANGES[base][1]):
                lo, hi = INT_RANGES[base]
                self._fail(d.pos, f"{d.name} is {base} but starts at {value!r}; expected a whole number in {lo}..{hi}")
            if base == "REAL" and isinstance(value, bool):
                self._fail(d.pos, f"{d.name} is REAL but starts at {value!r}")
        if d.type.bounds and len(values) > d.type.bounds[1] - d.type.bounds[0] + 1:
            self._fail(d.pos, f"{d.name} has {len(values)} start values for {d.type.bounds[1] - d.type.bounds[0] + 1} items")

    # -- running -----------------------------------------------------------------------------
    def reset(self) -> None:
        self.cycle = 0
        self.values = [self._initial(d) for d in self.decls]

    def _initial(self, d: s.VarDecl):
        zero = 0.0 if d.type.base == "REAL" else False if d.type.base == "BOOL" else 0
        if d.section == "temp":
            zero = UNSET
        if d.type.bounds:
            lo, hi = d.type.bounds
            init = d.initial if isinstance(d.initial, tuple) else ()
            return [self._literal_value(d, v) for v in init] + [zero] * (hi - lo + 1 - len(init))
        return zero if d.initial is None else self._literal_value(d, d.initial)

    def _literal_value(self, d: s.VarDecl, value):
        if d.type.base == "REAL" and isinstance(value, (int, float)) and not isinstance(value, bool):
            self._cell[0] = float(value)
            return self._cell[0]
        return value

    def call(self, inputs: dict) -> None:
        """One FB call with input values by name (REAL values must be binary32)."""
        v = self.values
        for name, value in inputs.items():
            v[self.slots[name.upper()]] = value
        for slot in self.temp_slots:
            v[slot] = [UNSET] * len(v[slot]) if isinstance(v[slot], list) else UNSET
        for slot in self.per_call_slots:
            v[slot] = True
        for stmt in self.body:
            stmt(v)
        self.cycle += 1

    def replay(self, columns: dict, rows: int, outputs: tuple[str, ...] | None = None,
               stop_after: int | None = None) -> dict:
        """Call once per row; columns maps input names to sequences. Returns the named outputs
        (all when None) as lists, one value per call."""
        v = self.values
        feed = [(self.slots[name.upper()], list(col)) for name, col in columns.items()]
        temps = [t for t in self.temp_slots if not isinstance(v[t], list)]
        temp_arrays = [t for t in self.temp_slots if isinstance(v[t], list)]
        names = [d.name for d in self.outputs] if outputs is None else outputs
        out_slots = [(name, self.slots[name.upper()]) for name in names]
        results = {name: [None] * rows for name, _ in out_slots}
        body = self.body
        last = rows if stop_after is None else min(rows, stop_after + 1)
        for j in range(last):
            for slot, col in feed:
                v[slot] = col[j]
            for t in temps:
                v[t] = UNSET
            for t in temp_arrays:
                v[t] = [UNSET] * len(v[t])
            for t in self.per_call_slots:
                v[t] = True
            for stmt in body:
                stmt(v)
            for name, slot in out_slots:
                results[name][j] = v[slot]
            self.cycle += 1
        return results

    def snapshot(self) -> dict:
        """Every variable except constants, after the last call (temps as that call left them)."""
        return {d.name: self.values[self.slots[d.name.upper()]] for d in self.decls if d.section != "constant"}

    # -- findings ------------------------------------------------------------------------------
    def _note(self, kind: str, pos: s.Pos, detail: str, runtime: bool = True) -> None:
        key = (kind, pos)
        finding = self.findings.get(key)
        if finding is None:
            finding = self.findings[key] = Finding(kind, pos, detail)
        if runtime:
            finding.count += 1
            if finding.first_cycle is None:
                finding.first_cycle = self.cycle

    def _check(self, r: float, pos: s.Pos, what: str) -> None:
        if r != r:
            self._note("nan", pos, f"{what} gives NaN")
        elif abs(r) > FLT_MAX:
            self._note("inf", pos, f"{what} gives {'+' if r > 0 else '-'}Inf")
        else:
            self._note("subnormal", pos, f"{what} gives a subnormal value {r!r}")

    def _fail(self, pos: s.Pos, message: str):
        raise InterpretError(f"{self.source}:{pos[0]}:{pos[1]}: {message}")

    def _failure(self, pos: s.Pos, message: str):
        raise BlockFailure(f"{self.source}:{pos[0]}:{pos[1]}: {message}")

    # -- compiling statements ----------------------------------------------------------------------
    def _block(self, stmts) -> list:
        out = []
        for st in stmts:
            if isinstance(st, s.Region):
                out.extend(self._block(st.body))
            else:
                out.append(self._stmt(st))
        return out

    def _stmt(self, st):
        if isinstance(st, s.Assign):
            return self._assign(st)
        if isinstance(st, s.If):
            branches = []
            for cond, body in st.branches:
                fn, kind = self._expr(cond)
                if kind != "BOOL":
                    self._fail(cond.pos, f"IF condition must be BOOL, found {kind}")
                branches.append((fn, self._block(body)))
            orelse = self._block(st.orelse)

            def run_if(v):
                for cond_fn, body in branches:
                    if cond_fn(v):
                        for stmt in body:
                            stmt(v)
                        return
                for stmt in orelse:
                    stmt(v)
            return run_if
        return self._for(st)

    def _for(self, st: s.For):
        decl = self._decl(st.var, st.pos)
        if decl.type.base not in INT_RANGES or decl.type.bounds:
            self._fail(st.pos, f"FOR variable {st.var} must be INT or DINT")
        slot = self.slots[st.var.upper()]
        start, stop = (self._int_expr(e) for e in (st.start, st.stop))
        step = self._int_expr(st.step) if st.step is not None else (lambda v: 1)
        body = self._block(st.body)
        fail, failure = self._fail, self._failure
        check = self._int_range_check(decl.type.base, st.pos)  # the counter is stored: an INT that wraps never ends

        def run_for(v):
            i, end, inc = start(v), stop(v), step(v)
            if inc == 0:
                failure(st.pos, "FOR step is 0")
            if self._loop_cycle != self.cycle:  # the budget is per call, over all loops (nested ones too)
                self._loop_total += self._loop_count
                self._loop_cycle, self._loop_count = self.cycle, 0
                if self._loop_total > MAX_REPLAY_LOOP_ITERATIONS:
                    fail(st.pos, f"FOR loops of this replay exceed {MAX_REPLAY_LOOP_ITERATIONS:,} iterations in the "
                                 f"interpreter (more than a minute); replay fewer rows or loop less per call")
            while (i <= end) if inc > 0 else (i >= end):
                self._loop_count += 1
                if self._loop_count > MAX_LOOP_ITERATIONS:
                    failure(st.pos, f"FOR loops of one call exceed {MAX_LOOP_ITERATIONS} iterations")
                v[slot] = check(i)
                for stmt in body:
                    stmt(v)
                i = v[slot] + inc
            v[slot] = check(i)
        return run_for

    def _int_expr(self, e):
        fn, kind = self._expr(e)
        if kind not in INT_RANGES:
            self._fail(e.pos, f"expected an INT expression, found {kind}")
        return fn

    def _decl(self, name: str, pos: s.Pos) -> s.VarDecl:
        slot = self.slots.get(name.upper())
        if slot is None:
            self._fail(pos, f"{name} is not declared")
        return self.decls[slot]

    def _assign(self, st: s.Assign):
        target = st.target
        decl = self._decl(target.name, target.pos)
        if decl.section in ("constant", "input"):
            self._fail(st.pos, f"assignment to {decl.section} {decl.name}")
        value, kind = self._expr(st.value)
        base = decl.type.base
        if (base == "REAL") != (kind == "REAL") or (base == "BOOL") != (kind == "BOOL"):
            self._fail(st.pos, f"assigns a {kind} value to {decl.name} of type {base}; convert explicitly")
        slot = self.slots[decl.name.upper()]
        check_int = self._int_range_check(base, st.pos)
        if isinstance(target, s.Index):
            if not decl.type.bounds:
                self._fail(target.pos, f"{decl.name} is not an array")
            index = self._int_expr(target.index)
            lo, hi = decl.type.bounds
            failure = self._failure

            def assign_item(v):
                i = index(v)
                if not lo <= i <= hi:
                    failure(target.pos, f"index {i} outside {decl.name}[{lo}..{hi}] at cycle {self.cycle}")
                v[slot][i - lo] = check_int(value(v))
            return assign_item
        if decl.type.bounds:
            self._fail(st.pos, f"whole-array assignment to {decl.name} is not supported")
        if base in INT_RANGES:
            return lambda v: v.__setitem__(slot, check_int(value(v)))

        def assign(v):
            v[slot] = value(v)
        return assign

    def _int_range_check(self, base: str, pos: s.Pos):
        if base not in INT_RANGES:
            return lambda x: x
        lo, hi = INT_RANGES[base]

        def check(x):
            if not lo <= x <= hi:
                self._note("int-overflow", pos, f"value {x} outside {base}")
                x = (x - lo) % (hi - lo + 1) + lo
            return x
        return check

    # -- compiling expressions -------------------------------------------------------------------------
    def _expr(self, e):
        if isinstance(e, s.RealLit):
            value = e.value
            return (lambda v: value), "REAL"
        if isinstance(e, s.IntLit):
            value = e.value
            return (lambda v: value), literal_kind(value)
        if isinstance(e, s.BoolLit):
            value = e.value
            return (lambda v: value), "BOOL"
        if isinstance(e, s.Name):
            return self._read(e)
        if isinstance(e, s.Index):
            return self._read_item(e)
        if isinstance(e, s.Unary):
            return self._unary(e)
        if isinstance(e, s.Call):
            return self._call(e)
        return self._binop(e)

    def _read(self, e: s.Name):
        decl = self._decl(e.name, e.pos)
        if decl.type.bounds:
            self._fail(e.pos, f"array {decl.name} used without an index")
        slot = self.slots[decl.name.upper()]
        kind = decl.type.base
        if decl.section != "temp":
            return (lambda v: v[slot]), kind
        failure = self._failure

        def read_temp(v):
            x = v[slot]
            if x is UNSET:
                failure(e.pos, f"VAR_TEMP {decl.name} is read before it is written in this call "
                            f"(its value at block start is undefined on the PLC)")
            return x
        return read_temp, kind

    def _read_item(self, e: s.Index):
        decl = self._decl(e.name, e.pos)
        if not decl.type.bounds:
            self._fail(e.pos, f"{decl.name} is not an array")
        slot = self.slots[decl.name.upper()]
        lo, hi = decl.type.bounds
        index = self._int_expr(e.index)
        failure = self._failure
        kind = decl.type.base

        def read_item(v):
            i = index(v)
            if not lo <= i <= hi:
                failure(e.pos, f"index {i} outside {decl.name}[{lo}..{hi}] at cycle {self.cycle}")
            x = v[slot][i - lo]
            if x is UNSET:
                failure(e.pos, f"VAR_TEMP {decl.name}[{i}] is read before it is written in this call")
            return x
        return read_item, kind

    def _operand(self, e, where: str):
        fn, kind = self._expr(e)
        if isinstance(e, s.RealLit):
            self._note("literal", e.pos, f"REAL literal {e.text} inside {where} (numeric contract rule 2: use a named constant)",
                       runtime=False)
        return fn, kind

    def _unary(self, e: s.Unary):
        fn, kind = self._expr(e.operand)
        if e.op == "NOT":
            if kind != "BOOL":
                self._fail(e.pos, f"NOT needs BOOL, found {kind}")
            return (lambda v: not fn(v)), "BOOL"
        if kind == "BOOL":
            self._fail(e.pos, "negation of a BOOL")
        if kind in INT_RANGES:
            check = self._int_range_check(kind, e.pos)
            return (lambda v: check(-fn(v))), kind
        return (lambda v: -fn(v)), kind

    def _round(self, pos: s.Pos, what: str):
        cell, check = self._cell, self._check

        def rounded(x: float) -> float:
            cell[0] = x
            r = cell[0]
            if not FLT_MIN_NORMAL <= abs(r) <= FLT_MAX and r != 0.0:
                check(r, pos, what)
            return r
        return rounded

    def _call(self, e: s.Call):
        args = [self._operand(a, f"a call of {e.func}") for a in e.args]
        kinds = [k for _, k in args]
        fns = [f for f, _ in args]
        if e.func in CONVERSIONS:
            if len(args) != 1 or kinds[0] not in INT_RANGES:
                self._fail(e.pos, f"{e.func} takes one INT argument")
            rnd = self._round(e.pos, e.func)
            f0 = fns[0]
            return (lambda v: rnd(float(f0(v)))), "REAL"
        if e.func in PORTABLE_REAL_FUNCTIONS or e.func in NON_PORTABLE_FUNCTIONS:
            arity = 2 if e.func in ("MIN", "MAX") else 1
            if len(args) != arity or any(k != "REAL" for k in kinds):
                self._fail(e.pos, f"{e.func} takes {arity} REAL argument{'s' if arity > 1 else ''}")
        else:
            self._fail(e.pos, f"call of {e.func} is not supported (portable functions: ABS, SQRT, MIN, MAX, INT_TO_REAL)")
        rnd = self._round(e.pos, e.func)
        if e.func == "ABS":
            f0 = fns[0]
            return (lambda v: abs(f0(v))), "REAL"
        if e.func == "SQRT":
            f0 = fns[0]
            return (lambda v: rnd(math.sqrt(x) if (x := f0(v)) >= 0 else math.nan)), "REAL"
        if e.func in ("MIN", "MAX"):
            f0, f1 = fns
            pick = min if e.func == "MIN" else max
            return (lambda v: pick(f0(v), f1(v))), "REAL"
        self._note("non-portable", e.pos, f"{e.func} is not correctly rounded on every PLC (numeric contract rule 4)", runtime=False)
        ufunc = NON_PORTABLE_FUNCTIONS[e.func]
        f0 = fns[0]

        def non_portable(v):
            with np.errstate(all="ignore"):
                return rnd(float(ufunc(np.float32(f0(v)))))
        return non_portable, "REAL"

    def _binop(self, e: s.BinOp):
        op = e.op
        arithmetic = op in ("+", "-", "*", "/", "MOD", "**")
        where = f"'{op}'"
        (lf, lk), (rf, rk) = (self._operand(e.left, where) if arithmetic else self._expr(e.left),
                              self._operand(e.right, where) if arithmetic else self._expr(e.right))
        if op in ("AND", "OR", "XOR"):
            if lk != "BOOL" or rk != "BOOL":
                self._fail(e.pos, f"{op} needs BOOL operands, found {lk} and {rk}")
            # both operands always: IEC 61131-3 leaves short-circuiting to the implementation (CODESYS
            # evaluates both), so an error in either operand must be seen
            if op == "AND":
                return (lambda v: all((lf(v), rf(v)))), "BOOL"
            if op == "OR":
                return (lambda v: any((lf(v), rf(v)))), "BOOL"
            return (lambda v: lf(v) != rf(v)), "BOOL"
        if lk != rk and not (lk in INT_RANGES and rk in INT_RANGES):
            self._fail(e.pos, f"'{op}' mixes {lk} and {rk}; convert explicitly (e.g. INT_TO_REAL)")
        if op in ("=", "<>", "<", "<=", ">", ">="):
            compare = {"=": lambda a, b: a == b, "<>": lambda a, b: a != b, "<": lambda a, b: a < b,
                       "<=": lambda a, b: a <= b, ">": lambda a, b: a > b, ">=": lambda a, b: a >= b}[op]
            return (lambda v: compare(lf(v), rf(v))), "BOOL"
        if lk == "BOOL":
            self._fail(e.pos, f"'{op}' on BOOL operands")
        if lk in INT_RANGES:
            kind = int_result_kind(lk, rk)
            return self._int_binop(e, lf, rf, kind), kind
        rnd = self._round(e.pos, f"'{op}'")
        if op == "+":
            return (lambda v: rnd(lf(v) + rf(v))), "REAL"
        if op == "-":
            return (lambda v: rnd(lf(v) - rf(v))), "REAL"
        if op == "*":
            return (lambda v: rnd(lf(v) * rf(v))), "REAL"
        if op == "/":
            return (lambda v: rnd(_divide(lf(v), rf(v)))), "REAL"
        if op == "**":
            self._note("non-portable", e.pos, "'**' is not correctly rounded on every PLC (numeric contract rule 4)", runtime=False)

            def power(v):
                with np.errstate(all="ignore"):
                    return rnd(float(np.power(np.float32(lf(v)), np.float32(rf(v)))))
            return power, "REAL"
        self._fail(e.pos, f"'{op}' on REAL operands is not supported")

    def _int_binop(self, e: s.BinOp, lf, rf, kind: str):
        failure = self._failure

        def divide(a, b, remainder):
            if b == 0:
                failure(e.pos, f"integer division by zero at cycle {self.cycle}")
            q = abs(a) // abs(b) * (1 if (a >= 0) == (b >= 0) else -1)  # truncates toward zero
            return a - q * b if remainder else q
        ops = {"+": lambda a, b: a + b, "-": lambda a, b: a - b, "*": lambda a, b: a * b,
               "/": lambda a, b: divide(a, b, False), "MOD": lambda a, b: divide(a, b, True)}
        if e.op not in ops:
            self._fail(e.pos, f"'{e.op}' on INT operands is not supported")
        f = ops[e.op]
        check = self._int_range_check(kind, e.pos)  # the intermediate's own type, as in the fast engine
        return lambda v: check(f(lf(v), rf(v)))


def _divide(a: float, b: float) -> float:
    """IEEE-754 division: x/0 is ±Inf, 0/0 and NaN operands give NaN."""
    if b != 0.0 or a != a or b != b:
        return a / b if b != 0.0 else math.nan
    if a == 0.0:
        return math.nan
    return math.copysign(math.inf, a) * math.copysign(1.0, b)
