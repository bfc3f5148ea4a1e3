"""The block IR: what a generated function block computes, with no dialect syntax in it.

Lowering builds it from a model; printers turn it into text. Expressions keep the exact tree
the float32 reference evaluates, so the printer must never regroup operands.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Union


class GenerationError(Exception):
    """The model cannot become a valid block (bad identifier, a constant an INT cannot hold, zero
    Kalman noise, ...): lowering and printing raise it, the CLI names the model file."""


@dataclass(frozen=True)
class Ref:
    name: str


@dataclass(frozen=True)
class BoolConst:
    value: bool


@dataclass(frozen=True)
class IntConst:
    """An INT literal: only as an array index, a loop bound or a value given to an INT variable
    (integer arithmetic is exact, so numeric contract rule 2 does not apply)."""
    value: int


@dataclass(frozen=True)
class Index:
    name: str
    index: "Expr"


@dataclass(frozen=True)
class BinOp:
    op: str  # + - * / < <= > >= = <> AND OR XOR
    left: "Expr"
    right: "Expr"


@dataclass(frozen=True)
class Unary:
    op: str  # '-' or 'NOT'
    operand: "Expr"


@dataclass(frozen=True)
class Call:
    func: str  # portable functions only: ABS, SQRT, MIN, MAX
    args: tuple["Expr", ...]


Expr = Union[Ref, BoolConst, IntConst, Index, BinOp, Unary, Call]


@dataclass(frozen=True)
class Assign:
    target: str
    value: Expr
    index: Expr | None = None  # assigns target[index] when set


@dataclass(frozen=True)
class If:
    branches: tuple[tuple[Expr, tuple["Stmt", ...]], ...]  # IF / ELSIF conditions with bodies
    orelse: tuple["Stmt", ...] = ()


@dataclass(frozen=True)
class For:
    var: str  # an INT variable
    start: Expr
    stop: Expr
    body: tuple["Stmt", ...]


@dataclass(frozen=True)
class Region:
    """A titled group of statements; it names the model term it computes (traceability) and may nest."""
    title: str
    body: tuple["Stmt", ...]


Stmt = Union[Assign, If, For, Region]


@dataclass(frozen=True)
class Var:
    name: str
    type: str  # 'REAL' | 'BOOL' | 'INT'
    comment: str = ""
    length: int | None = None  # Array[0..length-1] of type
    initial: tuple | bool | None = None  # start values of a table (REAL binary32 values), or a BOOL input's


# the enable output, IEC 61131-3's name: the dialect's system flag (TIA ENO, STEP 7 OK) or a declared output (IEC);
# the IR imports nothing, so the contract's ENO (contract/outputs.py) is the same name written once more, tested equal
ENO = "ENO"


@dataclass(frozen=True)
class Identity:
    """What the block header says about the block (TIA and STEP 7 attributes; comments in IEC)."""
    author: str = "thermopl"
    family: str = "ThermCmp"
    version: tuple[int, int] = (0, 1)
    date: str = ""
    name: str = ""  # the NAME attribute; empty: the block name cut to 8 characters (generator/identity.py)


@dataclass(frozen=True)
class Const:
    name: str
    value: float | int  # a binary32 value for REAL, an integer for INT
    comment: str = ""
    type: str = "REAL"


@dataclass(frozen=True)
class Block:
    name: str
    title: str
    header: tuple[str, ...]
    inputs: tuple[Var, ...]
    outputs: tuple[Var, ...]
    statics: tuple[Var, ...]
    temps: tuple[Var, ...]
    constants: tuple[Const, ...]
    regions: tuple[Region, ...]
    identity: Identity = Identity()
    retain: bool = False  # state (statics and outputs) kept over a power cycle


PORTABLE_FUNCTIONS = frozenset({"ABS", "SQRT", "MIN", "MAX"})


def walk_exprs(stmts: tuple[Stmt, ...]):
    """Every expression in a statement list, outermost first."""
    for stmt in stmts:
        if isinstance(stmt, Assign):
            if stmt.index is not None:
                yield from _walk(stmt.index)
            yield from _walk(stmt.value)
        elif isinstance(stmt, For):
            yield from _walk(stmt.start)
            yield from _walk(stmt.stop)
            yield from walk_exprs(stmt.body)
        elif isinstance(stmt, Region):
            yield from walk_exprs(stmt.body)
        else:
            for cond, body in stmt.branches:
                yield from _walk(cond)
                yield from walk_exprs(body)
            yield from walk_exprs(stmt.orelse)


def _walk(expr: Expr):
    yield expr
    if isinstance(expr, BinOp):
        yield from _walk(expr.left)
        yield from _walk(expr.right)
    elif isinstance(expr, Unary):
        yield from _walk(expr.operand)
    elif isinstance(expr, Call):
        for arg in expr.args:
            yield from _walk(arg)
    elif isinstance(expr, Index):
        yield from _walk(expr.index)


def assigned_names(stmts: tuple[Stmt, ...]):
    for stmt in stmts:
        if isinstance(stmt, Assign):
            yield stmt.target
        elif isinstance(stmt, For):
            yield stmt.var
            yield from assigned_names(stmt.body)
        elif isinstance(stmt, Region):
            yield from assigned_names(stmt.body)
        else:
            for _, body in stmt.branches:
                yield from assigned_names(body)
            yield from assigned_names(stmt.orelse)


def rename(stmts: tuple[Stmt, ...], names: dict) -> tuple[Stmt, ...]:
    """The statements with every variable in `names` (reads and writes) renamed."""
    def expr(e: Expr) -> Expr:
        if isinstance(e, Ref):
            return Ref(names.get(e.name, e.name))
        if isinstance(e, Index):
            return Index(names.get(e.name, e.name), expr(e.index))
        if isinstance(e, BinOp):
            return BinOp(e.op, expr(e.left), expr(e.right))
        if isinstance(e, Unary):
            return Unary(e.op, expr(e.operand))
        if isinstance(e, Call):
            return Call(e.func, tuple(expr(a) for a in e.args))
        return e

    def stmt(s: Stmt) -> Stmt:
        if isinstance(s, Assign):
            return Assign(names.get(s.target, s.target), expr(s.value), None if s.index is None else expr(s.index))
        if isinstance(s, For):
            return For(names.get(s.var, s.var), expr(s.start), expr(s.stop), rename(s.body, names))
        if isinstance(s, Region):
            return Region(s.title, rename(s.body, names))
        return If(tuple((expr(c), rename(b, names)) for c, b in s.branches), rename(s.orelse, names))

    return tuple(stmt(s) for s in stmts)
