"""Static range proof at generate: interval arithmetic over the block IR, for every call ever made.

Each REAL is an interval of binary32 values, each INT an integer interval, each BOOL the set of
values it can take. Binary32 rounding is monotone, so rounding the interval ends with the same
binary32 operation the PLC performs gives sound bounds without widening. The state of the block
(statics and outputs) gets an invariant: start from the start values, run one call with every
input anywhere in its guard range, join, and repeat (a bound that keeps moving jumps to the next
power of ten) until one call maps the state into itself. A final call over that invariant
reports every statement where a value can overflow to Inf, become NaN, be divided by a range
containing 0, become subnormal (a product or quotient of values bounded away from 0), exceed its
integer type or index outside its array.

Two forms the plain interval rule would blow up are recognised, because the Kalman update needs
them: `x + g*(z - x)` with g in [0, 1] lies between x and z, `p / (p + r)` with p, r >= 0 lies in
[0, 1], and `p - g*p` with p >= 0 and g in [0, 1] lies in [0, p] (each widened by the rounding).
IF branches narrow the variable they compare; paths stay apart inside a region (so a division
guarded by the branch that chose its operands is proven) and are joined at its end.

What it assumes: inputs are finite and inside their guard ranges (the guards handle the rest and
the fault replays test them). A value whose interval contains 0 is not checked for subnormals.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from thermoplc.base.binary32 import FLT_MAX, FLT_MIN_NORMAL, INT_RANGES, is_subnormal, round_f32
from thermoplc.generator.printer import statement_text
from thermoplc.generator.ir import (
    Assign, BinOp, Block, BoolConst, Call, Expr, For, If, Index, IntConst, Ref, Region, Stmt, Unary, Var,
)

MAX_PATHS = 64  # paths kept apart inside a region before they are joined
KLEENE_STEPS = 12  # calls joined one by one before moving bounds jump
MAX_STEPS = 400
MAX_LOOP_PASSES = 50
_INF = math.inf


@dataclass(frozen=True)
class Real:
    lo: float
    hi: float


@dataclass(frozen=True)
class Int:
    lo: int
    hi: int


@dataclass(frozen=True)
class Bool:
    values: frozenset


Value = Real | Int | Bool


@dataclass(frozen=True)
class RangeProof:
    problems: tuple[str, ...]  # "statement `...` (region ...): what can happen"
    ranges: dict  # every REAL variable -> (lo, hi) at the end of any call
    steps: int  # calls joined until the state invariant held


def join(a: Value, b: Value) -> Value:
    if isinstance(a, Bool):
        return Bool(a.values | b.values)
    return type(a)(min(a.lo, b.lo), max(a.hi, b.hi))


def _join_states(states: list[dict]) -> dict:
    out = dict(states[0])
    for s in states[1:]:
        for k, v in s.items():
            out[k] = join(out[k], v) if k in out else v
    return out


def _f32(x: float) -> float:
    return round_f32(x) if math.isfinite(x) else x


def _down(x: float, n: int = 2) -> float:
    """x moved n binary32 steps down (room for the rounding inside a recognised form); beyond the
    REAL range that is the largest REAL from above and -inf from below, without numpy's warning."""
    if n > 1:
        return _down(_down(x, 1), n - 1)
    with np.errstate(over="ignore"):
        return float(np.nextafter(np.float32(x), np.float32(-_INF)))


def _up(x: float, n: int = 2) -> float:
    return -_down(-x, n)


class _Proof:
    def __init__(self, block: Block, input_ranges: dict, partition: tuple[str, ...]):
        self.block = block
        self.partition = tuple(n for n in partition if any(v.name == n and v.type == "BOOL"
                                                           for v in (*block.outputs, *block.statics)))
        self.inputs = {v.name: Bool(frozenset({input_ranges[v.name]} if v.name in input_ranges else {False, True}))
                       if v.type == "BOOL" else Real(*input_ranges[v.name]) for v in block.inputs}
        self.constants = {c.name: (Int(c.value, c.value) if c.type == "INT" else Real(c.value, c.value))
                          for c in block.constants}
        self.decls: dict[str, Var] = {v.name: v for v in (*block.inputs, *block.outputs, *block.statics, *block.temps)}
        self.tables = {v.name: v.initial for v in block.statics if v.initial is not None}
        self.problems: dict[tuple, str] | None = None  # filled on the final pass only
        self.where = ("", "")

    # -- reporting
    def report(self, what: str) -> None:
        if self.problems is not None and self.where not in self.problems:
            self.problems[self.where] = what

    def real(self, lo: float, hi: float) -> Real:
        """An interval of binary32 results; Inf ends are overflows, subnormal ends of an interval that
        excludes 0 are underflows."""
        if math.isnan(lo) or math.isnan(hi):
            self.report("can become NaN")
            return Real(-_INF, _INF)
        if abs(lo) > FLT_MAX or abs(hi) > FLT_MAX:
            self.report(f"can overflow to Inf (range {lo:.7g}..{hi:.7g})")
        elif (lo > 0 and lo < FLT_MIN_NORMAL) or (hi < 0 and -hi < FLT_MIN_NORMAL):
            self.report(f"can become subnormal (range {lo:.7g}..{hi:.7g}; a PLC flushes it to 0 or reports underflow)")
        return Real(lo, hi)

    def integer(self, lo: int, hi: int, kind: str = "DINT") -> Int:
        low, high = INT_RANGES[kind]
        if lo < low or hi > high:
            self.report(f"can leave the {kind} range {low}..{high} (range {lo}..{hi})")
            return Int(max(lo, low), min(hi, high))
        return Int(lo, hi)

    # -- expressions
    def eval(self, e: Expr, state: dict) -> Value:
        if isinstance(e, Ref):
            if e.name in self.constants:
                return self.constants[e.name]
            return state[e.name]
        if isinstance(e, BoolConst):
            return Bool(frozenset({e.value}))
        if isinstance(e, IntConst):
            return Int(e.value, e.value)
        if isinstance(e, Index):
            return self.index(e.name, self.eval(e.index, state), state)
        if isinstance(e, Unary):
            x = self.eval(e.operand, state)
            if e.op == "NOT":
                return Bool(frozenset(not v for v in x.values))
            return Int(-x.hi, -x.lo) if isinstance(x, Int) else Real(-x.hi, -x.lo)
        if isinstance(e, Call):
            return self.call(e.func, [self.eval(a, state) for a in e.args])
        return self.binop(e, state)

    def index(self, name: str, i: Int, state: dict) -> Value:
        length = self.decls[name].length
        if i.lo < 0 or i.hi > length - 1:
            self.report(f"index {i.lo}..{i.hi} can leave {name}[0..{length - 1}]")
        lo, hi = max(i.lo, 0), min(i.hi, length - 1)
        if name in self.tables:
            values = self.tables[name][lo:hi + 1] or self.tables[name]
            return Real(min(values), max(values))
        return state[name]

    def call(self, func: str, args: list[Value]) -> Value:
        x = args[0]
        if func == "ABS":
            low = 0 if x.lo <= 0 <= x.hi else min(abs(x.lo), abs(x.hi))
            return type(x)(low, max(abs(x.lo), abs(x.hi)))
        if func == "SQRT":
            if x.lo < 0:
                self.report(f"SQRT of a range reaching below 0 gives NaN ({x.lo:.7g}..{x.hi:.7g})")
            return self.real(_f32(math.sqrt(max(x.lo, 0.0))), _f32(math.sqrt(max(x.hi, 0.0))))
        pick = min if func == "MIN" else max
        return type(x)(pick(a.lo for a in args), pick(a.hi for a in args))

    def binop(self, e: BinOp, state: dict) -> Value:
        if e.op in ("AND", "OR", "XOR"):
            a, b = self.eval(e.left, state), self.eval(e.right, state)
            f = {"AND": lambda p, q: p and q, "OR": lambda p, q: p or q, "XOR": lambda p, q: p != q}[e.op]
            return Bool(frozenset(f(p, q) for p in a.values for q in b.values))
        special = self.recognised(e, state)
        if special is not None:
            return special
        a, b = self.eval(e.left, state), self.eval(e.right, state)
        if e.op in ("<", "<=", ">", ">=", "=", "<>"):
            return _compare(e.op, a, b)
        if isinstance(a, Int):
            return self.int_arith(e.op, a, b)
        return self.real_arith(e.op, a, b, square=e.op == "*" and e.left == e.right)

    def int_arith(self, op: str, a: Int, b: Int) -> Int:
        if op == "/":
            if b.lo <= 0 <= b.hi:
                self.report(f"integer division by a range containing 0 ({b.lo}..{b.hi})")
                return self.integer(-abs(a.lo) - abs(a.hi), abs(a.lo) + abs(a.hi))
            ends = [int(x / y) for x in (a.lo, a.hi) for y in (b.lo, b.hi)]
        else:
            f = {"+": lambda x, y: x + y, "-": lambda x, y: x - y, "*": lambda x, y: x * y}[op]
            ends = [f(a.lo, b.lo), f(a.lo, b.hi), f(a.hi, b.lo), f(a.hi, b.hi)]
        return self.integer(min(ends), max(ends))

    def real_arith(self, op: str, a: Real, b: Real, square: bool = False) -> Real:
        if op == "+":
            return self.real(_f32(a.lo + b.lo), _f32(a.hi + b.hi))
        if op == "-":
            return self.real(_f32(a.lo - b.hi), _f32(a.hi - b.lo))
        if op == "/" and b.lo <= 0 <= b.hi:
            self.report(f"division by a range containing 0 ({b.lo:.7g}..{b.hi:.7g})")
            return Real(-_INF, _INF)
        f = (lambda x, y: x * y) if op == "*" else (lambda x, y: x / y)
        exact = [f(x, y) for x in (a.lo, a.hi) for y in (b.lo, b.hi) if not (math.isinf(x) or math.isinf(y))]
        if len(exact) < 4:
            return Real(-_INF, _INF)
        if (min(exact) > 0 or max(exact) < 0) and min(map(abs, exact)) < FLT_MIN_NORMAL:
            self.report(f"can become subnormal or underflow to 0 (range {min(exact):.7g}..{max(exact):.7g} of "
                        f"values that are never 0; a PLC flushes it to 0 or reports underflow)")
        ends = [_f32(x) for x in exact]
        lo, hi = min(ends), max(ends)
        if square and a.lo <= 0 <= a.hi:
            lo = 0.0
        return self.real(lo, hi)

    def recognised(self, e: BinOp, state: dict) -> Real | None:
        """The three forms of the Kalman update that plain intervals cannot bound (module docstring)."""
        if e.op == "+" and _is(e.right, "*") and _is(e.right.right, "-") and e.right.right.right == e.left:
            g = self.eval(e.right.left, state)
            if isinstance(g, Real) and 0 <= g.lo and g.hi <= 1:
                x, z = self.eval(e.left, state), self.eval(e.right.right.left, state)
                self.real_arith("*", g, self.real_arith("-", z, x))  # the parts must stay finite and normal
                return self.real(_down(min(x.lo, z.lo)), _up(max(x.hi, z.hi)))
        if e.op == "/" and _is(e.right, "+") and e.right.left == e.left:
            p, r = self.eval(e.left, state), self.eval(e.right.right, state)
            if isinstance(p, Real) and p.lo >= 0 and r.lo >= 0 and (p.lo > 0 or r.lo > 0):
                self.real_arith("+", p, r)
                low = _f32(p.lo / _f32(p.lo + r.hi)) if p.lo > 0 else 0.0
                high = _f32(p.hi / _f32(p.hi + r.lo)) if p.hi > 0 else 0.0
                return self.real(max(0.0, _down(low)), min(1.0, _up(high)))
        if e.op == "-" and _is(e.right, "*") and e.right.right == e.left:
            g, p = self.eval(e.right.left, state), self.eval(e.left, state)
            if isinstance(g, Real) and isinstance(p, Real) and 0 <= g.lo and g.hi <= 1 and p.lo >= 0:
                self.real_arith("*", g, p)
                low = _f32(p.lo - _f32(g.hi * p.lo))
                return self.real(max(0.0, _down(low)), p.hi)
        return None

    # -- conditions
    def narrow(self, cond: Expr, state: dict, truth: bool) -> dict | None:
        """The state on the paths where `cond` is `truth`, or None if there are none."""
        value = self.eval(cond, state)
        if truth not in value.values:
            return None
        if isinstance(cond, Unary) and cond.op == "NOT":
            return self.narrow(cond.operand, state, not truth)
        if isinstance(cond, Ref) and cond.name not in self.constants:
            return {**state, cond.name: Bool(frozenset({truth}))}
        if isinstance(cond, BinOp) and cond.op in ("AND", "OR") and truth == (cond.op == "AND"):
            left = self.narrow(cond.left, state, truth)
            return None if left is None else self.narrow(cond.right, left, truth)
        if isinstance(cond, BinOp) and cond.op in _FLIP:
            op = cond.op if truth else _NEGATE[cond.op]
            state = self._narrow_side(cond.left, op, self.eval(cond.right, state), state)
            if state is not None:
                state = self._narrow_side(cond.right, _FLIP[op], self.eval(cond.left, state), state)
            return state
        return state

    def _narrow_side(self, side: Expr, op: str, other: Value, state: dict) -> dict | None:
        if not isinstance(side, Ref) or side.name in self.constants or side.name not in state:
            return state
        x = state[side.name]
        if isinstance(x, Bool) or isinstance(other, Bool):
            return state
        lo, hi = x.lo, x.hi
        step = 1 if isinstance(x, Int) else 0
        if op in ("<", "<="):
            hi = min(hi, other.hi - (step if op == "<" else 0))
        elif op in (">", ">="):
            lo = max(lo, other.lo + (step if op == ">" else 0))
        elif op == "=":
            lo, hi = max(lo, other.lo), min(hi, other.hi)
        if lo > hi:
            return None
        return {**state, side.name: type(x)(lo, hi)}

    # -- statements
    def run(self, stmts: tuple[Stmt, ...], states: list[dict], region: str) -> list[dict]:
        for s in stmts:
            if isinstance(s, Region):
                states = self.group(self.run(s.body, states, s.title))
                continue
            self.where = (region, statement_text(s))
            if isinstance(s, Assign):
                states = [self.assign(s, st) for st in states]
            elif isinstance(s, If):
                states = self.branch(s, states, region)
            else:
                states = self.loop(s, states, region)
            if len(states) > MAX_PATHS:
                states = self.group(states)
        return states

    def key(self, state: dict) -> tuple:
        return tuple(state[name] for name in self.partition)

    def group(self, states: list[dict]) -> list[dict]:
        """Paths joined, apart for each combination of the partition's BOOLs (the first call and the calls
        before the model starts keep their own state)."""
        groups: dict[tuple, list[dict]] = {}
        for st in states:
            groups.setdefault(self.key(st), []).append(st)
        if len(groups) > MAX_PATHS:
            return [_join_states(states)]
        return [_join_states(g) for g in groups.values()]

    def assign(self, s: Assign, state: dict) -> dict:
        value = self.eval(s.value, state)
        decl = self.decls[s.target]
        if decl.type == "INT":
            value = self.integer(value.lo, value.hi, "INT")
        if s.index is None:
            return {**state, s.target: value}
        self.index(s.target, self.eval(s.index, state), state)
        return {**state, s.target: join(state[s.target], value)}

    def branch(self, s: If, states: list[dict], region: str) -> list[dict]:
        out = []
        for state in states:
            rest = state
            for cond, body in s.branches:
                self.where = (region, statement_text(s))
                taken = self.narrow(cond, rest, True)
                rest = self.narrow(cond, rest, False)
                if taken is not None:
                    out += self.run(body, [taken], region)
                if rest is None:
                    break
            if rest is not None:
                out += self.run(s.orelse, [rest], region)
        return out

    def loop(self, s: For, states: list[dict], region: str) -> list[dict]:
        state = _join_states(states)
        start, stop = self.eval(s.start, state), self.eval(s.stop, state)
        for _ in range(MAX_LOOP_PASSES):
            inside = {**state, s.var: Int(start.lo, max(start.lo, stop.hi))}
            after = _join_states([state, *self.run(s.body, [inside], region)])
            if after == state:
                return [{**state, s.var: Int(start.lo, max(start.lo, stop.hi + 1))}]
            state = after
        self.where = (region, statement_text(s))
        self.report(f"the values in the loop over {s.var} do not settle")
        return [state]

    # -- calls
    def one_call(self, invariant: dict) -> dict:
        """One call from every partition of the state; the ends grouped by partition, persistent part only."""
        fresh = {**self.inputs, **{v.name: _zero(v) for v in self.block.temps}}
        ends = self.run(self.block.regions, [{**st, **fresh} for st in invariant.values()], "")
        self.seen = _join_states(ends)
        persistent = next(iter(invariant.values()))
        return {self.key(st): {k: st[k] for k in persistent} for st in self.group(ends)}

    def start(self) -> dict:
        state = {v.name: _zero(v) for v in (*self.block.outputs, *self.block.statics) if v.name not in self.tables}
        return {self.key(state): state}


def _join_invariants(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, st in b.items():
        out[k] = {n: join(out[k][n], v) for n, v in st.items()} if k in out else st
    return out


def _zero(v: Var) -> Value:
    return {"REAL": Real(0.0, 0.0), "INT": Int(0, 0), "BOOL": Bool(frozenset({False}))}[v.type]


def _is(e: Expr, op: str) -> bool:
    return isinstance(e, BinOp) and e.op == op


_FLIP = {"<": ">", "<=": ">=", ">": "<", ">=": "<=", "=": "=", "<>": "<>"}
_NEGATE = {"<": ">=", "<=": ">", ">": "<=", ">=": "<", "=": "<>", "<>": "="}


def _compare(op: str, a: Value, b: Value) -> Bool:
    if isinstance(a, Bool):
        pairs = {(p, q) for p in a.values for q in b.values}
        return Bool(frozenset((p == q) == (op == "=") for p, q in pairs))
    can_true = {"<": a.lo < b.hi, "<=": a.lo <= b.hi, ">": a.hi > b.lo, ">=": a.hi >= b.lo,
                "=": a.lo <= b.hi and b.lo <= a.hi, "<>": not (a.lo == a.hi == b.lo == b.hi)}[op]
    can_false = {"<": a.hi >= b.lo, "<=": a.hi > b.lo, ">": a.lo <= b.hi, ">=": a.lo < b.hi,
                 "=": not (a.lo == a.hi == b.lo == b.hi), "<>": a.lo <= b.hi and b.lo <= a.hi}[op]
    return Bool(frozenset(v for v, ok in ((True, can_true), (False, can_false)) if ok))


def _widen(old: Value, new: Value, thresholds: tuple) -> Value:
    """A bound still moving jumps to the next threshold (the block's constants, the integer type
    limits, powers of ten, then infinity): the invariant search ends in a few steps, and the final
    check keeps it sound whatever the jump."""
    if isinstance(new, Bool) or new == old:
        return new
    lo = new.lo if new.lo == old.lo else -_next_threshold(-new.lo, thresholds)
    hi = new.hi if new.hi == old.hi else _next_threshold(new.hi, thresholds)
    if isinstance(new, Int):
        return Int(int(max(lo, -2.0 ** 63)), int(min(hi, 2.0 ** 63)))
    return Real(lo, hi)


def _thresholds(block: Block) -> tuple:
    values = {0.0, FLT_MAX}
    for c in block.constants:
        values |= {float(c.value), -float(c.value)} | ({float(c.value) + 1, -float(c.value) - 1} if c.type == "INT" else set())
    for low, high in INT_RANGES.values():
        values |= {float(low), float(high)}
    values |= {10.0 ** k for k in range(39)}
    return tuple(sorted(values))


def _next_threshold(x: float, thresholds: tuple) -> float:
    return next((t for t in thresholds if t >= x), _INF)


def _invariant(proof: "_Proof") -> tuple[dict, int]:
    """A state (per partition) that contains the start values and that one call maps into itself:
    joined calls, then jumps for bounds that keep moving, then narrowing (start values joined with
    one call over an invariant is again one) to take back what the jumps gave away."""
    start = proof.start()
    thresholds = _thresholds(proof.block)
    state = start
    for steps in range(1, MAX_STEPS + 1):
        after = _join_invariants(state, proof.one_call(state))
        if after == state:
            break
        if steps > KLEENE_STEPS:
            after = {k: ({n: _widen(state[k][n], v, thresholds) for n, v in st.items()} if k in state else st)
                     for k, st in after.items()}
        state = after
    for _ in range(KLEENE_STEPS):
        narrower = _join_invariants(start, proof.one_call(state))
        if narrower == state:
            break
        state = narrower
    return state, steps


def _contains(outer: dict, inner: dict) -> bool:
    return all(k in outer and all(join(outer[k][n], v) == outer[k][n] for n, v in st.items()) for k, st in inner.items())


def subnormal_values(block: Block) -> list[str]:
    """Declared REAL values a PLC that flushes subnormals to zero reads as 0: the block would compute
    with 0 where the reference computes with the tiny value, so no bit-exact claim could hold."""
    tiny = lambda v: isinstance(v, float) and is_subnormal(v)
    found = [f"constant {c.name} = {c.value!r} is subnormal" for c in block.constants if c.type == "REAL" and tiny(c.value)]
    for var in (*block.statics, *block.outputs):
        if var.type == "REAL" and isinstance(var.initial, tuple):
            found += [f"start value {var.name}[{k}] = {v!r} is subnormal" for k, v in enumerate(var.initial) if tiny(v)]
    return [f"{what} (a PLC that flushes subnormals reads 0; set it to 0 in the model or refit)" for what in found]


def prove_ranges(block: Block, input_ranges: dict, partition: tuple[str, ...] = ()) -> RangeProof:
    """The invariant of the block's state and the problems of the call over it (module docstring).
    `partition`: BOOL statics or outputs whose values keep separate states (latches such as the
    first-call flag), so the state before the first call does not blur the state after it."""
    proof = _Proof(block, input_ranges, partition)
    state, steps = _invariant(proof)
    proof.problems = {}
    if not _contains(state, proof.one_call(state)):
        proof.problems[("", "")] = "the search found no bound for the state that one call keeps"
    unbounded = sorted({n for st in state.values() for n, v in st.items()
                        if isinstance(v, Real) and (math.isinf(v.lo) or math.isinf(v.hi))})
    problems = [f"statement `{stmt}`{f' (region {region!r})' if region else ''}: {what}" if stmt else what
                for (region, stmt), what in proof.problems.items()]
    if unbounded:
        problems.append("state " + ", ".join(unbounded) + " can grow without bound")
    problems += subnormal_values(block)
    ranges = {k: (v.lo, v.hi) for k, v in proof.seen.items() if isinstance(v, Real) and k not in proof.inputs}
    return RangeProof(tuple(problems), ranges, steps)
