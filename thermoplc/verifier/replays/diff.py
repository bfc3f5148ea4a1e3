"""thermoplc diff: what changed between two blocks, in structure and (given data) in behaviour.

Works on parsed blocks, so layout, comments, keyword case and dialect do not count as changes;
changed constants, interface, state and statements do. With data, both blocks are replayed and
the largest output difference is reported with the call where it occurs.
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field, fields, is_dataclass, replace

import numpy as np

from thermoplc.base.binary32 import f32_bits
from thermoplc.base.errors import UserError
from thermoplc.contract.outputs import PROBE_NEW_INPUT, PROBE_VALUE_INPUT
from thermoplc.recordings.table import Table
from thermoplc.verifier.reading import syntax as s
from thermoplc.verifier.engines.choice import Replayer
from thermoplc.verifier.reading.block_file import parse_file, read_source
from thermoplc.verifier.replays.replay import block_columns
from thermoplc.verifier.engines.typed import differing_rows

SIEMENS_ATTRIBUTES = frozenset({"TITLE", "AUTHOR", "FAMILY", "NAME", "VERSION"})
SECTIONS = (("input", "input"), ("output", "output"), ("static", "state"), ("temp", "temporary"))  # section, one of it
WHOLE_BODY = "(body)"


@dataclass(frozen=True)
class ConstantChange:
    name: str
    old: object
    new: object

    @property
    def relative(self) -> float | None:
        if isinstance(self.old, (int, float)) and isinstance(self.new, (int, float)) and self.old != 0:
            return (float(self.new) - float(self.old)) / abs(float(self.old))
        return None


@dataclass(frozen=True)
class OutputDifference:
    output: str
    max_abs: float  # REAL: largest |new - old|; any other type: number of calls that differ
    cycle: int  # first call with that largest difference
    time: float
    differing_calls: int
    type: str  # the output's ST type (the new block's): REAL has max_abs in its unit, the others count calls

    @property
    def real(self) -> bool:
        return self.type == "REAL"


@dataclass
class BlockDiff:
    old: str
    new: str
    interface: list[str] = field(default_factory=list)  # '+ input X : REAL', '- state Y', '~ output Z: REAL -> BOOL'
    header: list[str] = field(default_factory=list)  # "~ TITLE: 'old' -> 'new'": the attributes a PLC shows
    constants: list[ConstantChange] = field(default_factory=list)
    statements: list[str] = field(default_factory=list)  # per region: what changed, with lines
    behaviour: list[OutputDifference] | None = None  # None: no data given
    cycles: int = 0

    @property
    def structurally_equal(self) -> bool:
        return not (self.header or self.interface or self.constants or self.statements)

    @property
    def behaviour_equal(self) -> bool:
        return self.behaviour is not None and all(d.differing_calls == 0 for d in self.behaviour)


def _same_value(a, b) -> bool:
    if isinstance(a, tuple) or isinstance(b, tuple):
        return (isinstance(a, tuple) and isinstance(b, tuple) and len(a) == len(b)
                and all(_same_value(x, y) for x, y in zip(a, b)))
    if isinstance(a, float) and isinstance(b, float):
        return f32_bits(a) == f32_bits(b)
    return type(a) is type(b) and a == b


def _type_text(t: s.TypeRef) -> str:
    return t.base if t.bounds is None else f"ARRAY[{t.bounds[0]}..{t.bounds[1]}] OF {t.base}"


def _interface(old: s.Program, new: s.Program) -> list[str]:
    lines = []
    for section, label in SECTIONS:
        before = {d.name.upper(): d for d in old.section(section)}
        after = {d.name.upper(): d for d in new.section(section)}
        lines += [f"- {label} {d.name} : {_type_text(d.type)}" for key, d in before.items() if key not in after]
        lines += [f"+ {label} {d.name} : {_type_text(d.type)}" for key, d in after.items() if key not in before]
        for key in before.keys() & after.keys():
            if before[key].type != after[key].type:
                lines.append(f"~ {label} {after[key].name}: {_type_text(before[key].type)} -> "
                             f"{_type_text(after[key].type)}")
    return sorted(lines, key=lambda line: line[2:])


def _unquoted(value):
    text = value.strip() if isinstance(value, str) else value
    return text[1:-1] if isinstance(text, str) and len(text) >= 2 and text[0] == text[-1] == "'" else text


def _header(old: s.Program, new: s.Program) -> list[str]:
    """Block name (case-insensitive, as ST names are), TITLE, AUTHOR, FAMILY, NAME and VERSION: shown
    to whoever opens the block; these attributes are compared when both blocks declare some (plain
    IEC text declares none). RETAIN sections and an instance DB are compared always."""
    both = all(any(k in SIEMENS_ATTRIBUTES for k, _ in p.header) for p in (old, new))

    def attributes(p: s.Program) -> list[tuple[str, str]]:  # STEP 7 quotes TITLE and VERSION, TIA does not
        # IEC declares no attributes (a dialect, not a change); RETAIN and an instance DB count always
        shown = [(k, _unquoted(v)) for k, v in p.header if both or k not in SIEMENS_ATTRIBUTES]
        return [("block name", p.name.upper()), *shown]
    before, after = attributes(old), attributes(new)
    if before == after:
        return []
    keys = dict.fromkeys(k for k, _ in before + after)
    lines = []
    for key in keys:
        a, b = [v for k, v in before if k == key], [v for k, v in after if k == key]
        if a != b:
            lines.append(f"~ {key}: {' '.join(map(repr, a)) or '(none)'} -> {' '.join(map(repr, b)) or '(none)'}")
    return lines


def _constants(old: s.Program, new: s.Program) -> list[ConstantChange]:
    """Named constants and every declared start value (tables, flags, counters, and inputs: an
    Enable that starts FALSE never runs on a PLC that does not wire it), each keyed by its section,
    so a value that moves from one section to another is a change too."""
    def values(p: s.Program) -> dict:
        return {(d.section, d.name.upper()): (d.name, d.initial) for d in p.decls
                if d.section == "constant" or d.initial is not None}
    before, after = values(old), values(new)
    changes = []
    for key in sorted(before.keys() | after.keys(), key=lambda k: (k[1], k[0])):
        name_old, value_old = before.get(key, (None, None))
        name_new, value_new = after.get(key, (None, None))
        if key in before and key in after and _same_value(value_old, value_new):
            continue
        if isinstance(value_old, tuple) and isinstance(value_new, tuple) and len(value_old) == len(value_new):
            changes += [ConstantChange(f"{name_new}[{k}]", a, b) for k, (a, b) in enumerate(zip(value_old, value_new))
                        if not _same_value(a, b)]
        else:
            changes.append(ConstantChange(name_new or name_old, value_old, value_new))
    return changes


def _regions(p: s.Program) -> dict[str, tuple]:
    """Top-level regions by title; statements outside regions (or a dialect without REGION) go under one key."""
    regions: dict[str, tuple] = {}
    loose: list = []
    for st in p.body:
        if isinstance(st, s.Region):
            regions[st.title] = regions.get(st.title, ()) + st.body
        else:
            loose.append(st)
    if loose:
        regions[WHOLE_BODY] = tuple(loose)
    return regions


def _flat(body: tuple) -> list:
    out = []
    for st in body:
        out.extend(_flat(st.body) if isinstance(st, s.Region) else [st])
    return out


def _folded(node):
    """The node with every variable name in upper case (ST names are case-insensitive, so `Cnt` and
    `CNT` are one variable) and every REAL literal by its binary32 value, not its spelling."""
    if isinstance(node, tuple):
        return tuple(_folded(item) for item in node)
    if not is_dataclass(node):
        return node
    changed = {f.name: _folded(getattr(node, f.name)) for f in fields(node) if f.compare}
    if isinstance(node, (s.Name, s.Index)):
        changed["name"] = node.name.upper()
    if isinstance(node, s.RealLit):  # 1.0 and 1.00 are one binary32 value on the PLC
        changed.update(text="", value=float(f32_bits(node.value)))
    return replace(node, **changed)


def _leaves(body) -> list[tuple[object, int]]:
    """Statements as a flat list of (comparable key, source line): an IF contributes its conditions
    and the leaves of its branches, so a change deep inside an IF is reported at its own line."""
    out: list[tuple[object, int]] = []
    for st in body:
        if isinstance(st, s.Region):
            out += _leaves(st.body)
        elif isinstance(st, s.If):
            for k, (cond, branch) in enumerate(st.branches):
                out.append((("IF" if k == 0 else "ELSIF", _folded(cond)), getattr(cond, "pos", st.pos)[0] or st.pos[0]))
                out += _leaves(branch)
            if st.orelse:
                out.append((("ELSE",), st.orelse[0].pos[0]))
                out += _leaves(st.orelse)
            out.append((("END_IF",), 0))
        elif isinstance(st, s.For):
            out.append((("FOR", st.var.upper(), _folded(st.start), _folded(st.stop), _folded(st.step)), st.pos[0]))
            out += _leaves(st.body)
            out.append((("END_FOR",), 0))
        else:
            out.append((_folded(st), st.pos[0]))
    return out


def _statements(old: s.Program, new: s.Program, old_lines: list[str], new_lines: list[str]) -> list[str]:
    a, b = _regions(old), _regions(new)
    if (WHOLE_BODY in a) != (WHOLE_BODY in b) or set(a) == {WHOLE_BODY} or set(b) == {WHOLE_BODY}:
        a, b = {WHOLE_BODY: tuple(_flat(old.body))}, {WHOLE_BODY: tuple(_flat(new.body))}  # one side has no REGIONs
    report = []
    if [t for t in a if t in b] != [t for t in b if t in a]:  # the same regions run in another order
        report.append("~ regions reordered: " + " | ".join(t for t in b if t in a))
    for title in [t for t in a if t not in b]:
        report.append(f"- region {title!r} removed ({len(a[title])} statements)")
    for title in [t for t in b if t not in a]:
        report.append(f"+ region {title!r} added ({len(b[title])} statements)")
    for title in [t for t in b if t in a]:
        before, after = _leaves(a[title]), _leaves(b[title])
        if [k for k, _ in before] == [k for k, _ in after]:
            continue
        matcher = difflib.SequenceMatcher(a=[k for k, _ in before], b=[k for k, _ in after], autojunk=False)
        for tag, i1, i2, j1, j2 in matcher.get_opcodes():
            if tag == "equal":
                continue
            where = "body" if title == WHOLE_BODY else f"region {title!r}"
            report.append(f"~ {where}: {i2 - i1} statement(s) replaced by {j2 - j1}")
            report += [f"    old line {line}: {old_lines[line - 1].strip()}" for _, line in before[i1:i2][:3] if line]
            report += [f"    new line {line}: {new_lines[line - 1].strip()}" for _, line in after[j1:j2][:3] if line]
    return report


def _behaviour(old_path: str, new_path: str, old: s.Program, new: s.Program, table: Table,
               overrides: dict | None, time_column: str) -> list[OutputDifference]:
    replayed = []
    for program, path in ((old, old_path), (new, new_path)):
        replayer = Replayer(program, path)
        columns = block_columns(replayer.inputs, table, overrides, path,
                                ", from its target with --probe-target COLUMN")
        takes_probings = any(d.name.upper() == PROBE_NEW_INPUT.upper() for d in replayer.inputs)
        if takes_probings and not any(name.upper() == PROBE_NEW_INPUT.upper() for name in columns):
            raise UserError(f"{path}: a fused block: without {PROBE_NEW_INPUT} no probing reaches it and its fusion "
                            f"is not compared; give --probe-target COLUMN (or columns {PROBE_VALUE_INPUT} and "
                            f"{PROBE_NEW_INPUT})")
        replayed.append(replayer.replay(columns, table.rows, tuple(d.name for d in replayer.outputs)))
    before, after = replayed
    old_outputs = {d.name.upper(): d for d in old.decls if d.section == "output"}
    new_outputs = [d for d in new.decls if d.section == "output"]
    times = table.columns.get(time_column, np.arange(table.rows, dtype=float))
    new_keys = {d.name.upper() for d in new_outputs}
    one_sided = [d for d in new_outputs if d.name.upper() not in old_outputs or old_outputs[d.name.upper()].type != d.type]
    one_sided += [d for key, d in old_outputs.items() if key not in new_keys]
    # an output only one block has, or of another type, differs on every call
    diffs = [OutputDifference(d.name, math.inf, 0, float(times[0]) if table.rows else 0.0, max(table.rows, 1),
                              d.type.base) for d in one_sided]
    for d in (d for d in new_outputs if d not in one_sided):
        a, b = before[old_outputs[d.name.upper()].name], after[d.name]
        differ = np.zeros(len(a), bool)
        differ[differing_rows(d.type.base, a, b)] = True
        if d.type.base == "REAL":
            with np.errstate(invalid="ignore"):
                gap = np.abs(np.asarray(b, np.float32).astype(np.float64) - np.asarray(a, np.float32).astype(np.float64))
            gap = np.where(differ, np.nan_to_num(gap, nan=np.inf), 0.0)
        else:
            gap = differ.astype(float)
        worst = int(np.argmax(gap)) if differ.any() else 0
        diffs.append(OutputDifference(d.name, float(gap[worst]) if d.type.base == "REAL" else float(differ.sum()),
                                      worst, float(times[worst]), int(differ.sum()), d.type.base))
    return diffs


def diff_blocks(old_path: str, new_path: str, table: Table | None = None, overrides: dict | None = None,
                time_column: str = "time_s") -> BlockDiff:
    old, new = parse_file(old_path), parse_file(new_path)
    old_lines, new_lines = read_source(old_path).splitlines(), read_source(new_path).splitlines()
    result = BlockDiff(old_path, new_path, _interface(old, new), _header(old, new), _constants(old, new),
                       _statements(old, new, old_lines, new_lines))
    if table is not None:
        result.behaviour = _behaviour(old_path, new_path, old, new, table, overrides, time_column)
        result.cycles = table.rows
    return result


def _show(value) -> str:
    if value is None:
        return "(none)"
    if isinstance(value, float):
        return str(np.float32(value))
    if isinstance(value, tuple):
        return f"table of {len(value)} values"
    return str(value)


def format_diff(d: BlockDiff) -> str:
    lines = [f"diff {d.old} -> {d.new}"]
    lines.append("header: " + ("unchanged" if not d.header else f"{len(d.header)} change(s)"))
    lines += [f"  {line}" for line in d.header]
    lines.append("interface: " + ("unchanged" if not d.interface else f"{len(d.interface)} change(s)"))
    lines += [f"  {line}" for line in d.interface]
    lines.append("constants: " + ("unchanged" if not d.constants else f"{len(d.constants)} changed"))
    for c in d.constants[:50]:
        rel = c.relative
        lines.append(f"  {c.name}: {_show(c.old)} -> {_show(c.new)}" + (f"  ({rel:+.3g} relative)" if rel is not None else ""))
    if len(d.constants) > 50:
        lines.append(f"  ... {len(d.constants) - 50} more")
    lines.append("statements: " + ("unchanged" if not d.statements else "changed"))
    lines += [f"  {line}" for line in d.statements]
    if d.behaviour is not None:
        same = d.behaviour_equal
        lines.append(f"behaviour on the data ({d.cycles} calls): " + ("identical, every output bit equal" if same else "DIFFERENT"))
        for b in d.behaviour:
            if b.differing_calls == 0:
                lines.append(f"  {b.output}: identical")
            elif math.isinf(b.max_abs):
                lines.append(f"  {b.output}: in one block only, or declared with another type: not comparable")
            elif not b.real:
                lines.append(f"  {b.output}: differs in {b.differing_calls} calls, first at call {b.cycle} (time {b.time:g} s)")
            else:
                lines.append(f"  {b.output}: differs in {b.differing_calls} calls; largest |new - old| = {b.max_abs:.6g} "
                             f"at call {b.cycle} (time {b.time:g} s)")
    return "\n".join(lines)
