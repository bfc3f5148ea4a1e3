"""The AST of a parsed block. Positions (line, column) are kept for messages but not compared."""
from __future__ import annotations

from dataclasses import dataclass, field, fields, is_dataclass
from typing import Union

Pos = tuple[int, int]


def position(text: str, offset: int) -> Pos:
    """The (line, column) of character `offset` of `text`, both counted from 1."""
    return text.count("\n", 0, offset) + 1, offset - (text.rfind("\n", 0, offset) + 1) + 1


def _pos():
    return field(default=(0, 0), compare=False, repr=False)


@dataclass(frozen=True)
class Name:
    name: str
    pos: Pos = _pos()


@dataclass(frozen=True)
class Index:
    name: str
    index: "Expr"
    pos: Pos = _pos()


@dataclass(frozen=True)
class RealLit:
    text: str
    value: float
    pos: Pos = _pos()


@dataclass(frozen=True)
class IntLit:
    value: int
    pos: Pos = _pos()


@dataclass(frozen=True)
class BoolLit:
    value: bool
    pos: Pos = _pos()


@dataclass(frozen=True)
class BinOp:
    op: str  # upper case: + - * / MOD ** = <> < <= > >= AND OR XOR
    left: "Expr"
    right: "Expr"
    pos: Pos = _pos()


@dataclass(frozen=True)
class Unary:
    op: str  # '-' or 'NOT'
    operand: "Expr"
    pos: Pos = _pos()


@dataclass(frozen=True)
class Call:
    func: str  # upper case
    args: tuple["Expr", ...]
    pos: Pos = _pos()


@dataclass(frozen=True)
class Member:
    """An output of a block instance (`Dut.Comp_X`): test benches only (verifier/reading/bench_source.py)."""
    instance: str
    name: str
    pos: Pos = _pos()


@dataclass(frozen=True)
class GlobalItem:
    """An item of a data block's array (`"TB_D1".In1[k]`): test benches only."""
    block: str
    name: str
    index: "Expr"
    pos: Pos = _pos()


Expr = Union[Name, Index, RealLit, IntLit, BoolLit, BinOp, Unary, Call, Member, GlobalItem]


@dataclass(frozen=True)
class Assign:
    target: Union[Name, Index]
    value: Expr
    pos: Pos = _pos()


@dataclass(frozen=True)
class If:
    branches: tuple[tuple[Expr, tuple["Stmt", ...]], ...]
    orelse: tuple["Stmt", ...]
    pos: Pos = _pos()


@dataclass(frozen=True)
class For:
    var: str
    start: Expr
    stop: Expr
    step: Expr | None
    body: tuple["Stmt", ...]
    pos: Pos = _pos()


@dataclass(frozen=True)
class Region:
    title: str
    body: tuple["Stmt", ...]
    pos: Pos = _pos()


@dataclass(frozen=True)
class BlockCall:
    """A call of a block instance with its inputs by name: test benches only."""
    instance: str
    arguments: tuple[tuple[str, Expr], ...]
    pos: Pos = _pos()


Stmt = Union[Assign, If, For, Region, BlockCall]


@dataclass(frozen=True)
class TypeRef:
    base: str  # upper case: REAL, BOOL, INT, DINT
    bounds: tuple[int, int] | None = None  # ARRAY[lo..hi] OF base
    block: str = ""  # an instance of this function block (test benches only); base is then "BLOCK"


@dataclass(frozen=True)
class VarDecl:
    name: str
    section: str  # input, output, inout, static, temp, constant
    type: TypeRef
    initial: object = None  # a literal value, a tuple for arrays, or None
    pos: Pos = _pos()


@dataclass(frozen=True)
class Program:
    name: str
    decls: tuple[VarDecl, ...]
    body: tuple[Stmt, ...]
    header: tuple[tuple[str, str], ...] = ()  # (TITLE, AUTHOR, FAMILY, NAME, VERSION, RETAIN or INSTANCE DB, text)
    per_call: tuple[str, ...] = ()  # BOOL outputs a call sets TRUE before the body runs (the SCL enable flag ENO)

    def section(self, section: str) -> tuple[VarDecl, ...]:
        return tuple(d for d in self.decls if d.section == section)


@dataclass(frozen=True)
class DataBlock:
    """A global data block of a test bench: its arrays with the values its BEGIN section gives."""
    name: str
    decls: tuple[VarDecl, ...]
    values: tuple[tuple[str, int, object], ...]  # (array, index, value), in the order written
    pos: Pos = _pos()


@dataclass(frozen=True)
class Sources:
    """A test bench source: its function blocks and data blocks, in the order written."""
    blocks: tuple[Program, ...]
    data_blocks: tuple[DataBlock, ...]


def names_read(node) -> frozenset[str]:
    """Every variable or constant the statements read, in upper case (ST names ignore case): the
    names in expressions, indices and FOR bounds, not the variable an assignment writes."""
    found: set[str] = set()

    def walk(item) -> None:
        if isinstance(item, tuple):
            for part in item:
                walk(part)
        elif isinstance(item, Assign):
            walk(item.target.index if isinstance(item.target, Index) else ())
            walk(item.value)
        elif is_dataclass(item):
            if isinstance(item, (Name, Index)):
                found.add(item.name.upper())
            for f in fields(item):
                walk(getattr(item, f.name))
    walk(node)
    return frozenset(found)
