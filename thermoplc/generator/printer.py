"""IR -> Structured Text. Knows the dialect's syntax, nothing about models."""
from __future__ import annotations

import re
from importlib import resources

import jinja2

from thermoplc.base.binary32 import INT_RANGES
from thermoplc.base.identifiers import check_unique, header_attribute_problem, identifier_problem
from thermoplc.generator.ir import (
    ENO, GenerationError,
    PORTABLE_FUNCTIONS, Assign, BinOp, Block, BoolConst, Call, Expr, For, Index, IntConst, Ref, Region, Stmt,
    Unary, Var, assigned_names, walk_exprs,
)
from thermoplc.generator.dialects import DialectDefinition, plcopen_wrapped, registry
from thermoplc.generator.identity import check_header_name
from thermoplc.generator.literals import real_literal

_PRECEDENCE = {"OR": 1, "XOR": 2, "AND": 3, "=": 4, "<>": 4, "<": 5, "<=": 5, ">": 5, ">=": 5,
               "+": 6, "-": 6, "*": 7, "/": 7}


INT_MIN, INT_MAX = INT_RANGES["INT"]


DIALECTS = registry()  # what differs between the dialects is in each one's record (generator/dialects/)


def safe_comment(text: str) -> str:
    """Comment text that cannot end the comment or the line: printable ASCII, no comment delimiters."""
    text = "".join(ch if " " <= ch <= "~" else "?" for ch in text)
    return re.sub(r"\(\*|\*\)|/\*|\*/|[{}]", "?", text).strip()


def safe_string(text: str) -> str:
    """Text that cannot end the quoted string it is printed in (the STEP 7 TITLE) or escape from it."""
    return re.sub(r"['\"$]", "?", safe_comment(text))


class _Printer:
    def __init__(self, dialect: DialectDefinition):
        self.d = dialect

    def name(self, name: str) -> str:
        if name == ENO and self.d.eno:
            return self.d.eno
        return self.d.local_prefix + name

    def expr(self, e: Expr) -> str:
        if isinstance(e, Ref):
            return self.name(e.name)
        if isinstance(e, BoolConst):
            return "TRUE" if e.value else "FALSE"
        if isinstance(e, IntConst):
            return str(e.value)
        if isinstance(e, Index):
            return f"{self.d.local_prefix}{e.name}[{self.expr(e.index)}]"
        if isinstance(e, Call):
            return f"{e.func}({', '.join(self.expr(a) for a in e.args)})"
        if isinstance(e, Unary):
            inner = self.expr(e.operand)
            if isinstance(e.operand, (BinOp, Unary)):
                inner = f"({inner})"
            return f"-{inner}" if e.op == "-" else f"NOT {inner}"
        prec = _PRECEDENCE[e.op]
        left = self.expr(e.left)
        if isinstance(e.left, BinOp) and _PRECEDENCE[e.left.op] < prec:
            left = f"({left})"
        right = self.expr(e.right)
        if (isinstance(e.right, BinOp) and _PRECEDENCE[e.right.op] <= prec) or isinstance(e.right, Unary):
            right = f"({right})"
        return f"{left} {e.op} {right}"

    def stmts(self, body: tuple[Stmt, ...], depth: int) -> list[str]:
        pad = self.d.body_indent + "    " * depth
        lines: list[str] = []
        for s in body:
            if isinstance(s, Assign):
                target = self.name(s.target)
                if s.index is not None:
                    target += f"[{self.expr(s.index)}]"
                lines.append(f"{pad}{target} := {self.expr(s.value)};")
                continue
            if isinstance(s, Region):
                lines.extend(self.region(s, depth))
                continue
            if isinstance(s, For):
                lines.append(f"{pad}FOR {self.d.local_prefix}{s.var} := {self.expr(s.start)} "
                             f"TO {self.expr(s.stop)} DO")
                lines.extend(self.stmts(s.body, depth + 1))
                lines.append(f"{pad}END_FOR;")
                continue
            for i, (cond, branch) in enumerate(s.branches):
                keyword = "IF" if i == 0 else "ELSIF"
                lines.append(f"{pad}{keyword} {self.expr(cond)} THEN")
                lines.extend(self.stmts(branch, depth + 1))
            if s.orelse:
                lines.append(f"{pad}ELSE")
                lines.extend(self.stmts(s.orelse, depth + 1))
            lines.append(f"{pad}END_IF;")
        return lines

    def region(self, r: Region, depth: int) -> list[str]:
        """A region at the depth of its neighbours, its body one level in; only TIA has the REGION keyword, the others get a comment."""
        pad = self.d.body_indent + "    " * depth
        title = safe_comment(r.title)
        if self.d.regions == "keyword":
            return [f"{pad}REGION {title}", *self.stmts(r.body, depth + 1), f"{pad}END_REGION"]
        return [f"{pad}(* {title} *)", *self.stmts(r.body, depth)]

    def body(self, regions: tuple[Region, ...]) -> list[str]:
        lines: list[str] = []
        for r in regions:
            lines.extend(self.region(r, 0))
            lines.append("")
        return lines


def validate(block: Block) -> None:
    """Refuse a block that breaks numeric contract rules 2 and 6, docs/numeric_contract.md: bad or duplicate names, undeclared references,
    non-portable functions, assignments to inputs or constants."""
    sections = (block.inputs, block.outputs, block.statics, block.temps)
    declared = {v.name: v for group in sections for v in group}
    constants = {c.name: c for c in block.constants}
    names = [block.name, *(v.name for group in sections for v in group), *(c.name for c in block.constants)]
    for name in names:
        problem = None if name == ENO else identifier_problem(name)
        if problem:
            raise GenerationError(f"identifier {name!r} {problem}")
    duplicate = check_unique(names)
    if duplicate:
        raise GenerationError(duplicate)
    body = tuple(block.regions)
    for e in walk_exprs(body):
        if isinstance(e, (Ref, Index)) and e.name not in declared and e.name not in constants:
            raise GenerationError(f"expression refers to undeclared {e.name!r}")
        if isinstance(e, BinOp) and e.op in "+-*/" and any(isinstance(x, IntConst) for x in (e.left, e.right)):
            raise GenerationError(f"integer literal inside arithmetic ({e.op}); declare a named INT constant")
        if isinstance(e, Call) and e.func not in PORTABLE_FUNCTIONS:
            raise GenerationError(f"{e.func} is not a portable operation (numeric contract rule 4)")
    writable = {v.name for group in (block.outputs, block.statics, block.temps) for v in group if v.initial is None}
    for target in assigned_names(body):
        if target not in writable:
            raise GenerationError(f"statement assigns {target!r}, which is not an output, static or temp")
    for c in block.constants:
        if c.type == "REAL":
            real_literal(c.value)  # raises for values that are not finite binary32
        elif c.type == "INT" and not INT_MIN <= c.value <= INT_MAX:
            raise GenerationError(f"constant {c.name} = {c.value} does not fit INT ({INT_MIN}..{INT_MAX}): {c.comment}")
    for v in (*block.statics, *block.temps):
        if v.length is not None and v.length - 1 > INT_MAX:
            raise GenerationError(f"array {v.name} of {v.length} values cannot be indexed by an INT ({v.comment})")
    for v in (*block.statics, *block.temps):
        for value in v.initial or ():
            real_literal(value)
    _validate_identity(block)


TITLE_MAX = 64  # STEP 7 SCL block attribute TITLE; TIA shows the same line in the block properties


def _validate_identity(block: Block) -> None:
    """Header attributes within the limits of STEP 7 SCL (the stricter target), so no import truncates them."""
    if len(safe_string(block.title)) > TITLE_MAX:
        raise GenerationError(f"title has {len(block.title)} characters; STEP 7 takes at most {TITLE_MAX}: {block.title!r}")
    identity = block.identity
    for what, value in (("author", identity.author), ("family", identity.family)):
        problem = header_attribute_problem(value)
        if problem:
            raise GenerationError(f"{what}: {problem}")
    if not all(0 <= part <= 15 for part in identity.version):
        raise GenerationError(f"version {identity.version[0]}.{identity.version[1]}: each part must be 0 to 15")
    if identity.date and not re.fullmatch(r"\d{4}-\d{2}-\d{2}", identity.date):
        raise GenerationError(f"date {identity.date!r}: expected YYYY-MM-DD")


def _initial(v: Var, style: str) -> str:
    """Start values of a table, six per line so that review diffs stay readable."""
    if v.initial is None:
        return ""
    if isinstance(v.initial, bool):
        return " := TRUE" if v.initial else " := FALSE"
    items = [real_literal(x) for x in v.initial]
    rows = [", ".join(items[i:i + 6]) for i in range(0, len(items), 6)]
    if style == "list":
        return " := " + ",\n         ".join(rows)
    return " := [" + ",\n         ".join(rows) + "]"


def _environment() -> jinja2.Environment:
    return jinja2.Environment(
        loader=jinja2.FunctionLoader(lambda name: resources.files("thermoplc.templates").joinpath(name).read_text("utf-8")),
        keep_trailing_newline=True, trim_blocks=True, lstrip_blocks=True, undefined=jinja2.StrictUndefined,
        autoescape=False,
    )


UNDATED = "2000-01-01T00:00:00"  # TC6 requires a creationDateTime: this one when no date is given (the API, goldens)


def plcopen_type(kind: str, bounds: tuple[int, int] | None = None, block: str = "") -> str:
    """A variable's <type> content: a scalar, a one-dimensional array of one, or an instance of a block."""
    if block:
        return f'<derived name="{block}"/>'
    if bounds is None:
        return f"<{kind}/>"
    return f'<array><dimension lower="{bounds[0]}" upper="{bounds[1]}"/><baseType><{kind}/></baseType></array>'


def plcopen_pou(name: str, version: str, title: str, created: str, header: list[str], sections: list, body: list[str]) -> str:
    """One function block as PLCopen TC6 XML; `sections` are (element, attributes, variables), each variable a
    dict of name, type_xml, simple (a start value's text or None), array (start values' texts), comment."""
    return _environment().get_template("plcopen.xml.j2").render(
        name=name, version=version, title=title, created=created, header=header, sections=sections, body=body)


def render_plcopen(block: Block, version: str) -> str:
    """The iec block wrapped as PLCopen TC6 XML (CODESYS, TwinCAT import). Its creationDateTime is the
    block's date (generate --date, or SOURCE_DATE_EPOCH, or today), the one the header comment states,
    at 00:00:00; without a date a fixed UNDATED: either way the same inputs give the same bytes."""
    validate(block)
    printer = _Printer(plcopen_wrapped())

    def decl(v: Var) -> dict:
        flag = isinstance(v.initial, bool)
        items = [real_literal(x) for x in v.initial] if v.initial is not None and not flag else []
        return {"name": v.name, "type_xml": plcopen_type(v.type, None if v.length is None else (0, v.length - 1)),
                "simple": ("TRUE" if v.initial else "FALSE") if flag else None, "array": items,
                "comment": safe_comment(v.comment)}

    constants = [{"name": c.name, "type_xml": plcopen_type(c.type), "array": [], "comment": safe_comment(c.comment),
                  "simple": real_literal(c.value) if c.type == "REAL" else str(c.value)} for c in block.constants]
    retain = ' retain="true"' if block.retain else ""
    sections = [(element, attributes, [decl(v) for v in group]) for element, attributes, group in
                (("inputVars", "", block.inputs), ("outputVars", retain, block.outputs), ("localVars", retain, block.statics),
                 ("tempVars", "", block.temps)) if group]
    if constants:
        sections.append(("localVars", ' constant="true"', constants))
    return plcopen_pou(block.name, version, safe_string(block.title),
                       f"{block.identity.date}T00:00:00" if block.identity.date else UNDATED,
                       [safe_comment(line) for line in _header(block, plcopen_wrapped())], sections,
                       printer.body(block.regions))


def render_instance_db(block: Block, db_name: str, dialect: str) -> str:
    """An instance DB source of the block in the dialect's template (classic STEP 7's), to append after the
    block's own source; its header attributes are the block's (VERSION, AUTHOR, NAME, FAMILY)."""
    problem = identifier_problem(db_name)
    if problem:
        raise GenerationError(f"instance DB name {db_name!r} {problem}")
    if db_name.upper() == block.name.upper():
        raise GenerationError(f"instance DB name {db_name!r} is the block's own name")
    return _environment().get_template(DIALECTS[dialect].instance_db).render(
        db=db_name, name=block.name, identity=block.identity,
        short_name=check_header_name(block.name, block.identity.name))


def _header(block: Block, d: DialectDefinition) -> list[str]:
    """The header comment: the block's own lines, the date, and how its state survives a power cycle."""
    lines = list(block.header)
    if block.identity.date:
        lines.append(f"Generated on {block.identity.date}.")
    if block.retain:
        lines.append("State retentive: statics and outputs declared RETAIN." if d.retain else
                     "State retentive: keep the instance DB retentive (S7-300: do not set 'Non Retain' on it).")
    else:
        lines.append("State not retentive: after a power cycle the block starts afresh (generate --retain keeps it).")
    return lines


def statement_text(s: Stmt) -> str:
    """One statement as a message names it: an assignment whole, an IF or FOR by its first line."""
    return " ".join(_Printer(DIALECTS["iec"]).stmts((s,), 0)[0].split())


def render(block: Block, dialect: str = "tia") -> str:
    """The block as source text, byte-identical for the same IR."""
    validate(block)
    d = DIALECTS[dialect]
    missing = {e.func for e in walk_exprs(block.regions) if isinstance(e, Call)} - d.functions
    if missing:
        raise GenerationError(f"the {dialect} dialect has no {', '.join(sorted(missing))}; lower it with IF")
    printer = _Printer(d)
    env = _environment()

    def type_of(v: Var) -> str:
        if v.length is None:
            return d.type_names[v.type]
        return d.array_type.format(last=v.length - 1, type=d.type_names[v.type])

    def decls(group):
        return [(v.name, type_of(v), _initial(v, d.array_initial), safe_comment(v.comment)) for v in group]

    retain = " RETAIN" if block.retain and d.retain else ""
    outputs = tuple(v for v in block.outputs if not (v.name == ENO and d.eno))
    text = env.get_template(d.template).render(
        name=block.name,
        title=safe_string(block.title),
        header=[safe_comment(line) for line in _header(block, d)],
        identity=block.identity,
        short_name=check_header_name(block.name, block.identity.name) if d.attributes else None,
        sections=[(kw, decls(group)) for kw, group in
                  (("VAR_INPUT", block.inputs), ("VAR_OUTPUT" + retain, outputs),
                   ("VAR" + retain, block.statics), ("VAR_TEMP", block.temps)) if group],
        constants=[(c.name, d.type_names[c.type], real_literal(c.value) if c.type == "REAL" else str(c.value),
                    safe_comment(c.comment)) for c in block.constants],
        body=printer.body(block.regions),
    )
    return text
