"""The grammar reads back what the printer writes, tree for tree, and rejects what it cannot run."""
import pytest
from hypothesis import given, settings

from thermoplc.generator import ir
from thermoplc.generator.lower import lower
from thermoplc.generator.printer import _Printer, DIALECTS, render
from thermoplc.verifier.reading import syntax as s
from thermoplc.verifier.reading.parser import StSyntaxError, parse_text
from tests.strategies import real_exprs


def to_ast(e):
    """The AST the parser must produce for an IR expression (positions are not compared)."""
    if isinstance(e, ir.Ref):
        return s.Name(e.name)
    if isinstance(e, ir.BoolConst):
        return s.BoolLit(e.value)
    if isinstance(e, ir.IntConst):
        return s.IntLit(e.value)
    if isinstance(e, ir.BinOp):
        return s.BinOp(e.op, to_ast(e.left), to_ast(e.right))
    if isinstance(e, ir.Unary):
        return s.Unary(e.op, to_ast(e.operand))
    return s.Call(e.func, tuple(to_ast(a) for a in e.args))


def stmts_to_ast(body):
    out = []
    for st in body:
        if isinstance(st, ir.Assign):
            out.append(s.Assign(s.Name(st.target), to_ast(st.value)))
        else:
            out.append(s.If(tuple((to_ast(c), stmts_to_ast(b)) for c, b in st.branches), stmts_to_ast(st.orelse)))
    return tuple(out)


def wrap(body_line: str) -> str:
    return f"FUNCTION_BLOCK \"B\"\nBEGIN\n{body_line}\nEND_FUNCTION_BLOCK\n"


@pytest.mark.parametrize("dialect", ["tia", "iec"])  # '#' names and bare names parse to the same tree
@given(expr=real_exprs())
@settings(max_examples=300, deadline=None)
def test_printed_expression_parses_to_the_same_tree(dialect, expr):
    printer = _Printer(DIALECTS[dialect])
    program = parse_text(wrap(f"{printer.d.local_prefix}y := {printer.expr(expr)};"))
    assert program.body[0].value == to_ast(expr)


@pytest.mark.parametrize("kind", ["mlr", "kalman"])
def test_generated_block_round_trips(kind, mlr_model, kalman_model):
    model = {"mlr": mlr_model, "kalman": kalman_model}[kind]
    block = lower(model)
    program = parse_text(render(block), "gen.scl")
    assert program.name == block.name
    regions = [st for st in program.body if isinstance(st, s.Region)]
    assert [r.title for r in regions] == [r.title for r in block.regions]
    for parsed, region in zip(regions, block.regions):
        assert parsed.body == stmts_to_ast(region.body)
    declared = {(d.name, d.section) for d in program.decls}
    expected = {(v.name, sec) for sec, group in (("input", block.inputs), ("output", block.outputs),
                                                  ("static", block.statics), ("temp", block.temps)) for v in group}
    expected |= {(c.name, "constant") for c in block.constants}
    assert declared == expected
    constants = {d.name: d.initial for d in program.decls if d.section == "constant"}
    assert all(constants[c.name] == c.value for c in block.constants)


@pytest.mark.parametrize("source, where, construct", [
    ("BEGIN\n  CASE #a OF 1: #b := 2.0; END_CASE;", "4:3", "CASE statement is not supported"),
    ("BEGIN\n  WHILE #a < #b DO #a := #b; END_WHILE;", "4:3", "WHILE loop is not supported"),
    ("VAR_IN_OUT\n  x : Real;\nEND_VAR\nBEGIN", "3:1", "VAR_IN_OUT section is not supported"),
    ("VAR\n  x : LReal;\nEND_VAR\nBEGIN", "4:3", "type LREAL is not supported"),
    ("VAR\n  s : String;\nEND_VAR\nBEGIN", "4:3", "type STRING is not supported"),
    ("BEGIN\n  #a := #b +;", "4:13", "syntax error"),
])
def test_unsupported_constructs_name_line_and_column(source, where, construct):
    text = f"FUNCTION_BLOCK \"B\"\n// a comment with CASE and WHILE in it\n{source}\nEND_FUNCTION_BLOCK\n"
    with pytest.raises(StSyntaxError) as info:
        parse_text(text, "block.scl")
    assert str(info.value).startswith(f"block.scl:{where}: ")
    assert construct in str(info.value)


def test_comments_case_and_attributes_are_accepted():
    text = """function_block "B"
{ S7_Optimized_Access := 'TRUE' }
TITLE = thermal compensation
AUTHOR : someone
VERSION : 0.1
(* a block comment
   over two lines *)
   var_input
      a { ExternalAccessible := 'False' } : real;  // note
   end_var
   VAR_OUTPUT y : Real; END_VAR
begin
    region free text, with (brackets) and while words
        #y := #a;   /* trailing */
    end_region;
end_function_block"""
    program = parse_text(text)
    assert [d.name for d in program.decls] == ["a", "y", "ENO"]  # SCL (BEGIN): the system enable output
    assert program.body[0].title == "free text, with (brackets) and while words"


def _tree_names(grammar: str) -> set[str]:
    """The names of the trees the grammar can build: each rule's alias, or its own name unless lark inlines it
    (`_rule`, or `?rule` on an alternative of one kept child)."""
    from lark import Lark
    from lark.grammar import NonTerminal
    parser = Lark(grammar, parser="lalr", start=["start", "st_body", "constant", "sources"])
    names = set()
    for rule in parser.rules:
        kept = [sym for sym in rule.expansion if isinstance(sym, NonTerminal) or not sym.filter_out]
        if rule.alias:
            names.add(rule.alias)
        elif not rule.origin.name.startswith("_") and not (rule.options.expand1 and len(kept) == 1):
            names.add(rule.origin.name)
    return names


def test_every_grammar_rule_is_turned_into_the_ast_or_refused():
    """As blark checks its grammar: every tree the grammar builds has a method of the block's transformer or the
    test bench's (which refuses what a block under test may not hold), and no method waits for a tree the
    grammar never builds. A rule added to st.lark without its handling would reach the interpreter as a raw
    lark tree."""
    from pathlib import Path

    from thermoplc.verifier.reading import bench_source, parser
    names = _tree_names((Path(parser.__file__).parent / "st.lark").read_text("utf-8"))
    handled = {name for cls in (parser._ToAst, bench_source._BenchToAst) for name in vars(cls)
               if not name.startswith("_")}
    assert names - handled == set(), "grammar trees nothing turns into the AST"
    assert handled - names == set(), "handlers of trees the grammar never builds"


def test_the_rule_check_sees_a_rule_left_unhandled():
    from pathlib import Path

    from thermoplc.verifier.reading import parser
    grammar = (Path(parser.__file__).parent / "st.lark").read_text("utf-8")
    grammar = grammar.replace('| ";" -> empty', '| ";" -> empty | "EXIT"i ";" -> exit_stmt', 1)
    assert "exit_stmt" in _tree_names(grammar)
