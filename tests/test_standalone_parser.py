"""The standalone parser (verifier/reading/st_standalone.py, written by scripts/regen_parser.py) is the grammar's parser:
built from the same st.lark and giving the same trees, tokens, positions and errors as lark building it."""
from __future__ import annotations

import hashlib
from functools import lru_cache

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st
from lark import Lark, Token as LarkToken, Tree as LarkTree
from lark.exceptions import UnexpectedInput as LarkUnexpectedInput

from scripts.regen_parser import GRAMMAR, OPTIONS
from tests.golden_models import DIALECTS, KINDS, golden_block
from tests.strategies import real_exprs
from thermoplc.generator.printer import DIALECTS as PRINTER_DIALECTS, _Printer
from thermoplc.verifier.reading import st_standalone
from thermoplc.verifier.reading.parser import _lark


@lru_cache(maxsize=1)
def built() -> Lark:
    return Lark(GRAMMAR.read_text("utf-8"), strict=True, **OPTIONS)


def shape(node):
    """A tree as nested tuples: rule, token type and text, and every position lark propagates."""
    if isinstance(node, (LarkToken, st_standalone.Token)):
        return ("token", node.type, str(node), node.line, node.column, node.end_line, node.end_column, node.start_pos)
    if isinstance(node, (LarkTree, st_standalone.Tree)):
        meta = node.meta
        where = (meta.line, meta.column, meta.end_line, meta.end_column) if not meta.empty else None
        return (str(node.data), where, tuple(shape(child) for child in node.children))
    return node


def outcome(parser, text: str, start: str):
    """The tree's shape, or where and why the text is refused."""
    try:
        return shape(parser.parse(text, start=start))
    except (LarkUnexpectedInput, st_standalone.UnexpectedInput) as exc:
        return ("refused", type(exc).__name__, exc.line, exc.column)


def test_the_standalone_parser_was_generated_from_this_grammar():
    digest = hashlib.sha256(GRAMMAR.read_text("utf-8").encode("utf-8")).hexdigest()
    head = GRAMMAR.parent.joinpath("st_standalone.py").read_text("utf-8").splitlines()[1]
    assert head == f"# st.lark sha256: {digest}", "st.lark changed: run python scripts/regen_parser.py"


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("dialect", DIALECTS)
def test_golden_blocks_parse_to_the_same_trees(kind, dialect):
    text = golden_block(kind, dialect).read_text("utf-8")
    expected = outcome(built(), text, "start")
    assert expected[0] != "refused"
    assert outcome(_lark(), text, "start") == expected


def _block(statement: str) -> str:
    return f'FUNCTION_BLOCK "B"\nVAR_TEMP\n  y : REAL;\nEND_VAR\nBEGIN\n{statement}\nEND_FUNCTION_BLOCK\n'


@given(expr=real_exprs(), dialect=st.sampled_from(DIALECTS))
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_generated_expressions_parse_to_the_same_trees(expr, dialect):
    printer = _Printer(PRINTER_DIALECTS[dialect])
    text = _block(f"{printer.d.local_prefix}y := {printer.expr(expr)};")
    assert outcome(_lark(), text, "start") == outcome(built(), text, "start")


WORDS = st.sampled_from(["IF", "THEN", "ELSIF", "ELSE", "END_IF", ";", ":=", "#y", "y", "(", ")", "1.5", "16#FF",
                         "REGION", "END_REGION", "FOR", "TO", "DO", "END_FOR", "+", "*", "AND", "NOT", "(*c*)",
                         "//c\n", "\n", " ", "'s'", "E", "-", "REAL#2.0", "TRUE"])


@given(words=st.lists(WORDS, max_size=25), start=st.sampled_from(["start", "st_body", "constant"]))
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_generated_text_gets_the_same_tree_or_the_same_refusal(words, start):
    text = " ".join(words)
    text = _block(text) if start == "start" else text
    assert outcome(_lark(), text, start) == outcome(built(), text, start)
