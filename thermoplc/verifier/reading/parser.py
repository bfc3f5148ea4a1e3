"""Structured Text text -> AST (verifier/reading/syntax.py), with file:line:col messages for anything else."""
from __future__ import annotations


import math
import re
from functools import lru_cache

import numpy as np

from thermoplc.base.binary32 import decimal_to_f32
from thermoplc.base.errors import UserError
from thermoplc.verifier.reading import syntax as s
from thermoplc.verifier.reading.one_reading import refuse_two_readings
from thermoplc.verifier.reading.st_standalone import (
    Lark, Lark_StandAlone, Token, Transformer, UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken,
    VisitError, v_args,
)

MAX_SOURCE_CHARACTERS = 4_000_000  # 20x the largest generated block; bounds parse time and memory
MAX_ARRAY_ELEMENTS = 1_000_000

SUPPORTED_TYPES = {"REAL", "BOOL", "INT", "DINT"}
# Constructs that are valid ST but outside the subset the verifier interprets.
UNSUPPORTED_WORDS = {
    "CASE": "CASE statement", "WHILE": "WHILE loop", "REPEAT": "REPEAT loop", "GOTO": "GOTO",
    "RETURN": "RETURN statement", "EXIT": "EXIT statement", "CONTINUE": "CONTINUE statement",
    "VAR_IN_OUT": "VAR_IN_OUT section", "VAR_GLOBAL": "VAR_GLOBAL section", "VAR_EXTERNAL": "VAR_EXTERNAL section",
    "STRUCT": "STRUCT type", "POINTER": "POINTER type", "REF_TO": "REF_TO reference", "REF": "REF()",
    "FUNCTION": "FUNCTION (only one FUNCTION_BLOCK per file)", "PROGRAM": "PROGRAM", "TYPE": "TYPE declaration",
    "DATA_BLOCK": "DATA_BLOCK", "ORGANIZATION_BLOCK": "ORGANIZATION_BLOCK", "METHOD": "METHOD",
    "INTERFACE": "INTERFACE", "ACTION": "ACTION", "AT": "AT address",
}

# A body held apart from its declarations (PLCopen XML) is statements only.
BODY_FRAME_WORDS = {word: f"{word} in the body (statements only: the XML's <interface> declares the variables)"
                    for word in ("VAR", "VAR_INPUT", "VAR_OUTPUT", "VAR_TEMP", "END_VAR", "CONST", "END_CONST", "BEGIN",
                                 "FUNCTION_BLOCK", "END_FUNCTION_BLOCK")}


_STATEMENTS = (s.Assign, s.If, s.For, s.Region, s.BlockCall)
DINT_MAX = 2 ** 31 - 1


class _HeaderItem(tuple):
    """One header attribute, (key, text), told apart from declarations in the start rule."""


class _InstanceDb(tuple):
    """(DB name, FB name) of a STEP 7 instance DB source after the block."""


class _Section(list):
    """The declarations of one VAR section; `retained` names the section when it is declared RETAIN."""

    def __init__(self, decls, retained: str):
        super().__init__(decls)
        self.retained = retained


_BEGIN = object()  # SCL's BEGIN: its blocks have the system flags ENO (TIA) and OK (STEP 7, copied to ENO)
SYSTEM_FLAGS = {"ENO", "OK"}


def _with_system_flag(name: str, body: tuple) -> tuple:
    """Assignments to the SCL enable flag (ENO, or OK which STEP 7 copies to ENO) written to one name, ENO."""
    def stmt(st):
        if isinstance(st, s.Assign):
            if isinstance(st.target, s.Name) and st.target.name.upper() in SYSTEM_FLAGS:
                return s.Assign(s.Name(name, st.target.pos), st.value, st.pos)
            return st
        if isinstance(st, s.If):
            return s.If(tuple((c, tuple(map(stmt, b))) for c, b in st.branches), tuple(map(stmt, st.orelse)), st.pos)
        if isinstance(st, s.For):
            return s.For(st.var, st.start, st.stop, st.step, tuple(map(stmt, st.body)), st.pos)
        if isinstance(st, s.BlockCall):
            return st
        return s.Region(st.title, tuple(map(stmt, st.body)), st.pos)
    return tuple(map(stmt, body))


class StSyntaxError(UserError):
    pass


def array_type(low: int, high: int, base: str, where: str) -> s.TypeRef:
    """ARRAY[low..high] OF base, refused beyond MAX_ARRAY_ELEMENTS; `where` names the file in the message."""
    if not 0 <= high - low < MAX_ARRAY_ELEMENTS:
        raise UserError(f"{where}: ARRAY[{low}..{high}] has {high - low + 1:,} elements; the verifier holds "
                        f"at most {MAX_ARRAY_ELEMENTS:,} per array (a block's tables and ring buffers are far smaller)")
    return s.TypeRef(base, (low, high))


@lru_cache(maxsize=1)
def _lark() -> Lark:
    """The parser of st.lark, its tables built once by scripts/regen_parser.py (not in every process). Starts:
    `start` a whole block source; `st_body` the statements of a body kept apart from its declarations and
    `constant` one start value written apart (both as PLCopen XML holds them, verifier/reading/plcopen.py)."""
    return Lark_StandAlone()


def _at(meta_or_token) -> s.Pos:
    return (getattr(meta_or_token, "line", 0), getattr(meta_or_token, "column", 0))


class _ToAst(Transformer):
    def __init__(self, source: str, where: str = ""):
        super().__init__()
        self.source = source
        self.where = where  # a literal read apart (PLCopen's start values): its place in the file, for messages

    def _fail(self, pos: s.Pos, message: str):
        raise StSyntaxError(f"{self.where or f'{self.source}:{pos[0]}:{pos[1]}'}: {message}")

    # declarations -------------------------------------------------------------------------
    def start(self, items):
        name = items[0]
        decls = tuple(d for item in items[1:] if isinstance(item, list) for d in item)
        body = tuple(item for item in items[1:] if isinstance(item, _STATEMENTS))
        header = tuple(item for item in items[1:] if isinstance(item, _HeaderItem))
        for item in items[1:]:
            if isinstance(item, _InstanceDb) and item[1].upper() != name.upper():
                raise StSyntaxError(f"{self.source}: DATA_BLOCK {item[0]!r} is an instance of {item[1]!r}, not of the "
                                    f"block {name!r} before it")
        retained = sorted({item.retained for item in items[1:] if isinstance(item, _Section) and item.retained})
        if retained:  # a diff shows it: what survives a power cycle is part of the block's behaviour
            header += (("RETAIN", ", ".join(retained)),)
        header += tuple(("INSTANCE DB", item[0]) for item in items[1:] if isinstance(item, _InstanceDb))
        declared = {d.name.upper() for d in decls}
        per_call = ()
        if any(item is _BEGIN for item in items[1:]) and not declared & SYSTEM_FLAGS:
            # SCL: every call starts with the enable flag TRUE (ENO in TIA, OK copied to ENO in STEP 7)
            decls = (*decls, s.VarDecl("ENO", "output", s.TypeRef("BOOL")))  # TRUE at every call: per_call
            body = _with_system_flag("ENO", body)
            per_call = ("ENO",)
        return s.Program(name, decls, body, header, per_call)

    def block_name(self, items):
        return str(items[0]).strip('"')

    def title(self, items):
        text = re.sub(r"(?i)^TITLE[ \t]*=[ \t]*", "", str(items[0]))
        return _HeaderItem(("TITLE", text))

    def author(self, items):
        return _HeaderItem(("AUTHOR", str(items[0])))

    def family(self, items):
        return _HeaderItem(("FAMILY", str(items[0])))

    def name_info(self, items):
        return _HeaderItem(("NAME", str(items[0])))

    def version(self, items):
        return _HeaderItem(("VERSION", str(items[0])))

    def instance_db(self, items):
        return _InstanceDb((items[0], items[1]))

    def begin(self, items):
        return _BEGIN

    sec_input = lambda self, _: ("input", False)
    sec_output = lambda self, items: ("output", bool(items))
    sec_inout = lambda self, _: ("inout", False)
    sec_temp = lambda self, _: ("temp", False)
    sec_constant = lambda self, _: ("constant", False)
    sec_static = lambda self, items: ("static", bool(items))

    @v_args(meta=True)
    def var_section(self, meta, items):
        (section, retained), decls = items[0], items[1:]
        if section == "inout":
            self._fail(_at(meta), "VAR_IN_OUT section is not supported")
        return _Section([s.VarDecl(d.name, section, d.type, d.initial, d.pos) for group in decls for d in group],
                        section if retained else "")

    @v_args(meta=True)
    def var_decl(self, meta, items):
        names = [t for t in items if isinstance(t, Token) and t.type == "NAME"]
        type_ref = next(i for i in items if isinstance(i, s.TypeRef))
        initial = items[-1] if not isinstance(items[-1], (Token, s.TypeRef)) else None
        if type_ref.base not in SUPPORTED_TYPES:
            self._fail(_at(meta), f"type {type_ref.base} is not supported (REAL, BOOL, INT, DINT and arrays of them are)")
        return [s.VarDecl(str(n), "", type_ref, initial, _at(n)) for n in names]

    def const_section(self, items):
        return list(items)

    def const_decl(self, items):
        name, value = items
        base = "BOOL" if isinstance(value, bool) else "INT" if isinstance(value, int) else "REAL"
        return s.VarDecl(str(name), "constant", s.TypeRef(base), value, _at(name))

    def _bench_only(self, what: str, at) -> None:
        self._fail(_at(at), f"{what} in a block under test: only a test bench calls a block or reads a data block")

    @v_args(meta=True)
    def fb_call(self, meta, items):
        self._bench_only("a call of another block", meta)

    @v_args(meta=True)
    def member(self, meta, items):
        self._bench_only(f"{items[0].name}.{items[1]}", meta)

    @v_args(meta=True)
    def global_item(self, meta, items):
        self._bench_only(f"{items[0]}.{items[1]}", meta)

    def block_type(self, items):
        self._bench_only(f"an instance of {items[0]}", items[0])

    def fb_argument(self, items):
        return str(items[0]), items[1]

    def scalar_type(self, items):
        return s.TypeRef(str(items[0]).upper())

    def array_type(self, items):
        return array_type(items[0], items[1], str(items[2]).upper(), self.source)

    def initial(self, items):
        return items[0]

    def st_body(self, items):
        return tuple(item for item in items if item is not None)

    def array_initial(self, items):
        return tuple(items)

    def constant(self, items):
        item = items[0]
        if isinstance(item, Token):
            return item.type == "TRUE"
        return item

    def signed_real(self, items):
        text = "".join(str(t) for t in items if t is not None).replace("_", "")
        value = decimal_to_f32(text)
        if math.isinf(value):
            self._fail(_at(items[-1]), f"REAL {text} is beyond the largest REAL (3.4028235e38)")
        self._one_rounding(text, value, items[-1])
        return value

    def _one_rounding(self, text: str, value: float, token) -> None:
        """A decimal that rounds to one REAL straight and to another through a double (as a compiler that
        parses with strtod and then narrows reads it) is read two ways: refused, with the shorter text."""
        via_double = float(np.float32(float(text)))
        if via_double != value and not (math.isnan(via_double) or math.isnan(value)):
            self._fail(_at(token), f"REAL {text} rounds to {value!r} straight to binary32 but to {via_double!r} "
                                   f"through a double, as some compilers read it; write it with at most 9 "
                                   f"significant digits")

    def signed_int(self, items):
        value = int("".join(str(t) for t in items if t is not None).replace("_", ""))
        if not -DINT_MAX - 1 <= value <= DINT_MAX:
            self._fail(_at(items[-1]), f"integer {value} does not fit DINT ({-DINT_MAX - 1}..{DINT_MAX})")
        return value

    # statements ----------------------------------------------------------------------------
    @v_args(meta=True)
    def assignment(self, meta, items):
        return s.Assign(items[0], items[1], _at(meta))

    def empty(self, items):
        return None

    @v_args(meta=True)
    def if_stmt(self, meta, items):
        cond, rest = items[0], items[1:]
        body = tuple(x for x in rest if isinstance(x, _STATEMENTS))
        branches = [(cond, body)] + [x[1] for x in rest if isinstance(x, tuple) and x[0] == "ELSIF"]
        orelse = next((x[1] for x in rest if isinstance(x, tuple) and x[0] == "ELSE"), ())
        return s.If(tuple(branches), orelse, _at(meta))

    def elsif(self, items):
        return ("ELSIF", (items[0], tuple(x for x in items[1:] if x is not None)))

    def else_part(self, items):
        return ("ELSE", tuple(x for x in items if x is not None))

    @v_args(meta=True)
    def for_stmt(self, meta, items):
        var, start, stop, step = items[:4]
        body = tuple(x for x in items[4:] if x is not None)
        return s.For(var.name, start, stop, step, body, _at(meta))

    @v_args(meta=True)
    def region(self, meta, items):
        title = re.sub(r"(?i)^REGION\b", "", str(items[0])).strip()
        return s.Region(title, tuple(x for x in items[1:] if x is not None), _at(meta))

    def lvalue(self, items):
        return items[0]

    @v_args(meta=True)
    def indexed(self, meta, items):
        return s.Index(items[0].name, items[1], _at(meta))

    @v_args(meta=True)
    def variable(self, meta, items):
        return s.Name(str(items[-1]), _at(meta))

    # expressions ---------------------------------------------------------------------------
    @v_args(meta=True)
    def arith(self, meta, items):
        return s.BinOp(str(items[1]).upper(), items[0], items[2], _at(meta))

    compare = arith

    @v_args(meta=True)
    def and_(self, meta, items):
        return s.BinOp("AND", items[0], items[-1], _at(meta))

    @v_args(meta=True)
    def or_(self, meta, items):
        return s.BinOp("OR", items[0], items[1], _at(meta))

    @v_args(meta=True)
    def xor_(self, meta, items):
        return s.BinOp("XOR", items[0], items[1], _at(meta))

    @v_args(meta=True)
    def power(self, meta, items):
        return s.BinOp("**", items[0], items[1], _at(meta))

    @v_args(meta=True)
    def neg(self, meta, items):
        return s.Unary("-", items[0], _at(meta))

    @v_args(meta=True)
    def not_(self, meta, items):
        return s.Unary("NOT", items[0], _at(meta))

    def real(self, items):
        token = items[0]
        text = re.sub(r"(?i)^REAL#", "", str(token)).replace("_", "")
        value = decimal_to_f32(text)
        if math.isinf(value):
            self._fail(_at(token), f"REAL literal {token} is beyond the largest REAL (3.4028235e38)")
        self._one_rounding(text, value, token)
        return s.RealLit(str(token), value, _at(token))

    def int(self, items):
        value = int(str(items[0]).replace("_", ""))
        if value > DINT_MAX:
            self._fail(_at(items[0]), f"integer literal {items[0]} does not fit DINT (at most {DINT_MAX})")
        return s.IntLit(value, _at(items[0]))

    def true(self, items):
        return s.BoolLit(True, _at(items[0]))

    def false(self, items):
        return s.BoolLit(False, _at(items[0]))

    def ref(self, items):
        return items[0]

    @v_args(meta=True)
    def index(self, meta, items):
        return s.Index(items[0].name, items[1], _at(meta))

    @v_args(meta=True)
    def call(self, meta, items):
        return s.Call(str(items[0]).upper(), tuple(a for a in items[1:] if a is not None), _at(meta))


def _blank_free_text(text: str) -> str:
    """Replace comments, strings, titles and region captions by spaces, keeping every position."""
    pattern = re.compile(r"//[^\n]*|\(\*.*?\*\)|/\*.*?\*/|'(?:[^'$\n]|\$[^\n])*'|\"[^\"\n]*\"|\{[^{}]*\}"
                         r"|(?i:\bREGION\b[^\n]*)", re.S)
    return pattern.sub(lambda m: re.sub(r"[^\n]", " ", m.group()), text)


def _explain(text: str, source: str, exc: UnexpectedInput, ending: str = "file (missing END_FUNCTION_BLOCK?)",
             words: dict[str, str] = UNSUPPORTED_WORDS, at_end: bool = False) -> str:
    """The one-line message of a refused text; `at_end`: the error is where the text ends."""
    at_end = at_end or isinstance(exc, UnexpectedEOF)
    error_offset = None if at_end else getattr(exc, "pos_in_stream", None)
    if error_offset is None:
        error_offset = len(text)
    blanked = _blank_free_text(text)
    for match in re.finditer(r"[A-Za-z_][A-Za-z0-9_]*", blanked):
        if match.start() > error_offset:
            break
        construct = words.get(match.group().upper())
        if construct:
            line, col = s.position(text, match.start())
            return f"{source}:{line}:{col}: {construct} is not supported"
    if at_end:
        line, col = s.position(text, len(text))
        return f"{source}:{line}:{col}: unexpected end of {ending}"
    if isinstance(exc, UnexpectedCharacters):
        return f"{source}:{exc.line}:{exc.column}: unexpected character {text[exc.pos_in_stream]!r}"
    assert isinstance(exc, UnexpectedToken)
    expected = sorted(exc.expected)[:8]
    found = "end of file" if exc.token.type == "$END" else repr(str(exc.token))
    return f"{source}:{exc.line}:{exc.column}: syntax error: unexpected {found}; expected one of {', '.join(expected)}"


def parse_text(text: str, source: str = "<text>") -> s.Program:
    if len(text) > MAX_SOURCE_CHARACTERS:
        raise StSyntaxError(f"{source}: {len(text):,} characters; a function block source is at most "
                            f"{MAX_SOURCE_CHARACTERS:,} here (the largest generated block is about 200,000)")
    return parsed_from(text, source, "start", _ToAst(source))


def parsed_from(text: str, source: str, start: str, to_ast: "_ToAst",
                ending: str = "file (missing END_FUNCTION_BLOCK?)"):
    """`text` parsed from grammar rule `start` and transformed by `to_ast`, or a StSyntaxError naming the place;
    `ending` names what a text that stops too early lacks."""
    refuse_two_readings(text, source)
    try:
        tree = _lark().parse(text, start=start)
    except UnexpectedInput as exc:
        raise StSyntaxError(_explain(text, source, exc, ending)) from None
    return _transform(tree, to_ast, source)


def _transform(tree, to_ast: _ToAst, source: str):
    try:
        return to_ast.transform(tree)
    except VisitError as exc:
        if isinstance(exc.orig_exc, UserError):
            raise exc.orig_exc from None
        if isinstance(exc.orig_exc, RecursionError):
            raise StSyntaxError(f"{source}: expressions or statements nested too deeply to read "
                                f"(thousands of levels); nothing written") from None
        raise


def parse_body(text: str, source: str, line: int = 1, column: int = 1, to_ast: "_ToAst | None" = None) -> tuple[s.Stmt, ...]:
    """The statements of a body held apart from its declarations (the ST text of a PLCopen POU),
    with positions counted from (line, column), where the text starts in `source`; declarations,
    BEGIN or a block frame in the text are syntax errors. `to_ast`: another transformer (a test
    bench's body calls the block under test: verifier/reading/bench_source.py)."""
    if len(text) > MAX_SOURCE_CHARACTERS:
        raise StSyntaxError(f"{source}:{line}:{column}: {len(text):,} characters of ST; a function block body is at "
                            f"most {MAX_SOURCE_CHARACTERS:,} here (the largest generated block is about 200,000)")
    padded = "\n" * (line - 1) + " " * (column - 1) + text  # lark counts positions from here: the file's own
    refuse_two_readings(padded, source)
    try:
        tree = _lark().parse(padded, start="st_body")
    except UnexpectedInput as exc:
        at_end = isinstance(exc, UnexpectedToken) and exc.token.type == "$END"  # its place is the end of the text
        raise StSyntaxError(_explain(padded, source, exc, "the body (an IF, FOR or REGION not closed?)",
                                     {**UNSUPPORTED_WORDS, **BODY_FRAME_WORDS}, at_end)) from None
    return _transform(tree, to_ast or _ToAst(source), source)


def parse_literal(text: str, source: str, where: str):
    """One start value written apart from its declaration (a PLCopen simpleValue) by the rules of
    a declaration's `:= value`: a REAL as binary32, an integer within DINT, TRUE or FALSE. `where`
    (file:line:column) names its place in messages."""
    try:
        tree = _lark().parse(text, start="constant")
    except UnexpectedInput:
        raise StSyntaxError(f"{where}: {text!r} is not a start value an ST declaration takes; expected a number, "
                            f"TRUE or FALSE") from None
    return _transform(tree, _ToAst(source, where), source)
