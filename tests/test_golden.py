"""Golden blocks: the generator's output for the committed model files, byte for byte, in every dialect.

After an intended generator change run `python scripts/regen_golden.py` and review the diff.
"""
import re
import xml.etree.ElementTree as ET

import pytest
from blark.parse import parse_source_code

from tests.golden_models import DIALECTS, GOLDEN, KINDS, golden_block, golden_twin_csv, rendered
from thermoplc.base.identifiers import identifier_problem
from thermoplc.models.modelfile import load_model
from thermoplc.recordings.table import read_table
from thermoplc.verifier.reading.block_file import parse_file
from thermoplc.verifier.replays.replay import verify_against_model
from thermoplc.verifier.reading import syntax as s


@pytest.fixture(scope="module")
def golden_table(tmp_path_factory):
    return read_table(golden_twin_csv(tmp_path_factory.mktemp("golden")))


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("dialect", (*DIALECTS, "plcopen"))
def test_generator_output_matches_golden_file(kind, dialect):
    assert rendered(kind, dialect) == golden_block(kind, dialect).read_text()


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("dialect", DIALECTS)
def test_golden_blocks_verify_bit_exact(kind, dialect, golden_table):
    model_path = GOLDEN / f"{kind}.json"
    report = verify_against_model(str(golden_block(kind, dialect)), load_model(model_path), str(model_path),
                                  golden_table)
    assert report.ok, report.text()
    assert report.cycles == golden_table.rows
    assert not report.findings, report.text()


@pytest.mark.parametrize("kind", [pytest.param(k, marks=() if k in ("mlr", "kalman", "dlag") else pytest.mark.slow)
                                  for k in KINDS])  # blark takes up to 12 s on the large tables
def test_blark_parses_every_iec_block(kind):
    result = parse_source_code(golden_block(kind, "iec").read_text())
    assert result.exception is None, result.exception


@pytest.mark.parametrize("kind", KINDS)
def test_plcopen_is_well_formed_and_carries_the_iec_body(kind):
    ns = {"p": "http://www.plcopen.org/xml/tc6_0201", "x": "http://www.w3.org/1999/xhtml"}
    root = ET.parse(golden_block(kind, "plcopen")).getroot()
    pou = root.find("p:types/p:pous/p:pou", ns)
    assert pou.get("pouType") == "functionBlock"
    body = pou.find("p:body/p:ST/x:p", ns).text
    iec = golden_block(kind, "iec").read_text()
    assert body.strip() in iec
    inputs = [v.get("name") for v in pou.findall("p:interface/p:inputVars/p:variable", ns)]
    assert inputs == [d.name for d in parse_file(golden_block(kind, "iec")).decls if d.section == "input"]


def _exprs(stmts):
    for st in stmts:
        if isinstance(st, s.Assign):
            yield st.value
        elif isinstance(st, s.If):
            for cond, body in st.branches:
                yield cond
                yield from _exprs(body)
            yield from _exprs(st.orelse)
        elif isinstance(st, s.For):
            yield from (st.start, st.stop)
            yield from _exprs(st.body)
        elif isinstance(st, s.Region):
            yield from _exprs(st.body)


def _literals(e):
    if isinstance(e, s.RealLit):
        yield e
    for child in (getattr(e, "left", None), getattr(e, "right", None), getattr(e, "operand", None),
                  getattr(e, "index", None), *getattr(e, "args", ())):
        if child is not None:
            yield from _literals(child)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("dialect", DIALECTS)
def test_identifiers_obey_design_and_no_expression_holds_a_real_literal(kind, dialect):
    program = parse_file(golden_block(kind, dialect))
    names = [program.name, *(d.name for d in program.decls)]
    assert [n for n in names if identifier_problem(n) and n != "ENO"] == []  # ENO: the enable output by its standard name
    assert len({n.upper() for n in names}) == len(names)
    assert [lit.text for e in _exprs(program.body) for lit in _literals(e)] == []


def test_step7_uses_no_tia_syntax():
    for kind in KINDS:
        text = golden_block(kind, "step7").read_text()
        code = re.sub(r"//[^\n]*|\(\*.*?\*\)", "", text, flags=re.S)
        assert "#" not in code and "+=" not in code and "REGION" not in code.upper().replace("END_REGION", "")
        assert not re.search(r"\b(MIN|MAX|LIMIT|LREAL)\b", code), kind
