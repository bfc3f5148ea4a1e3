"""verify reads blocks as engineers leave them after the IDE: exported, commented, reformatted.

Every variant of a generated block must verify with exactly the results of the original; every
construct outside the subset must be rejected with file:line:col and the construct's name.
"""
import re
from pathlib import Path

import pytest

from tests.golden_models import GOLDEN, golden_block, golden_twin_csv
from thermoplc.base.errors import UserError
from thermoplc.models.modelfile import load_model
from thermoplc.recordings.table import read_table
from thermoplc.verifier.replays.replay import verify_against_model

KEYWORDS = ("IF", "THEN", "ELSIF", "ELSE", "END_IF", "NOT", "AND", "BEGIN", "END_REGION", "REGION", "VAR_INPUT",
            "VAR_OUTPUT", "VAR_TEMP", "END_VAR", "FOR", "TO", "DO", "END_FOR", "TRUE", "FALSE", "OR")


def tia_export_header(text: str) -> str:
    """What TIA Portal writes when it exports a block: title, author, family, attributes per variable."""
    text = text.replace("{ S7_Optimized_Access := 'TRUE' }",
                        "TITLE = Thermal compensation spindle 1\n{ S7_Optimized_Access := 'TRUE' }\n"
                        "AUTHOR : Mueller\nFAMILY : Thermal", 1)
    return re.sub(r"^(\s+)(\w+) : (Real|Bool|Int);", r"\1\2 { ExternalAccessible := 'False'; S7_SetPoint := 'False'} : \3;",
                  text, flags=re.M)


def comments_everywhere(text: str) -> str:
    text = re.sub(r";\n", "; // checked\n", text)
    text = text.replace("BEGIN\n", "BEGIN\n(* Commissioning note:\n   values checked on machine 4711 *)\n/* C-style */\n")
    return text


def free_region_text(text: str) -> str:
    counter = iter(range(1000))
    return re.sub(r"REGION [^\n]*", lambda m: f"REGION Abschnitt {next(counter)} (geprüft: ok, 100 %)", text)


def blank_lines_crlf_spaces(text: str) -> str:
    return text.replace("\t", "    ").replace(";\n", ";\n\n").replace("\n", "\r\n")


def keyword_case(text: str) -> str:
    pattern = re.compile(r"\b(" + "|".join(KEYWORDS) + r")\b")
    return pattern.sub(lambda m: m.group().lower(), text).replace("Real", "REAL").replace("Bool", "bool")


VARIANTS = [tia_export_header, comments_everywhere, free_region_text, blank_lines_crlf_spaces, keyword_case,
            lambda t: keyword_case(comments_everywhere(tia_export_header(t)))]


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    return read_table(golden_twin_csv(tmp_path_factory.mktemp("reformatted")))


def _verify(path, kind, table):
    return verify_against_model(str(path), load_model(GOLDEN / f"{kind}.json"), str(GOLDEN / f"{kind}.json"), table)


@pytest.mark.parametrize("kind", ["kalman", "lumped", "bayes"])
@pytest.mark.parametrize("dialect", ["tia", "step7", "iec"])
@pytest.mark.parametrize("variant", range(len(VARIANTS)))
def test_reformatted_block_verifies_like_the_original(kind, dialect, variant, table, tmp_path):
    original = _verify(golden_block(kind, dialect), kind, table)
    path = tmp_path / f"edited{golden_block(kind, dialect).suffix}"
    path.write_bytes(VARIANTS[variant](golden_block(kind, dialect).read_text()).encode("utf-8"))
    edited = _verify(path, kind, table)
    assert edited.ok, edited.text()
    assert (edited.cycles, edited.outputs, edited.constants_checked) == \
           (original.cycles, original.outputs, original.constants_checked)


UNSUPPORTED = [
    ("    CASE #Init OF 1: #Ready := TRUE; END_CASE;", "CASE statement is not supported"),
    ("    WHILE #Init DO #Ready := TRUE; END_WHILE;", "WHILE loop is not supported"),
    ("    REPEAT #Ready := TRUE; UNTIL #Init END_REPEAT;", "REPEAT loop is not supported"),
    ("    RETURN;", "RETURN statement is not supported"),
    ("    GOTO lbl;", "GOTO is not supported"),
]


def _rejection(line_after: str, inserted: str, table, tmp_path) -> tuple[str, int, Path]:
    """The message verify gives for the golden mlr block with one line inserted after `line_after`."""
    lines = golden_block("mlr", "tia").read_text().splitlines()
    at = lines.index(line_after) + 1
    lines.insert(at, inserted)
    path = tmp_path / "bad.scl"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(UserError) as error:
        _verify(path, "mlr", table)
    return str(error.value), at + 1, path


@pytest.mark.parametrize("statement, construct", UNSUPPORTED)
def test_unsupported_statement_is_named_at_its_line_and_column(statement, construct, table, tmp_path):
    message, line, path = _rejection("BEGIN", statement, table, tmp_path)
    assert message == f"{path}:{line}:5: {construct}"


@pytest.mark.parametrize("declaration, construct", [
    ("      Spare : LReal;", "type LREAL is not supported"),
    ("      Spare AT %MW10 : Int;", "AT address is not supported"),
    ("      Spare : String;", "type STRING is not supported"),
])
def test_unsupported_declaration_is_named_at_its_line(declaration, construct, table, tmp_path):
    message, line, path = _rejection("   VAR ", declaration, table, tmp_path)
    assert message.startswith(f"{path}:{line}:") and f": {construct}" in message
