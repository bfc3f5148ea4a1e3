"""The dialects are one registry (generator/dialects/, issue 66): the CLI's choices, the printer, the test bench and
the recognition of a block file all read it, so a dialect is one module and its template."""
import argparse
from pathlib import Path

import pytest

from tests.golden_models import golden_block
from thermoplc.cli import build_parser
from thermoplc.generator import printer, testbench, testbench_text
from thermoplc.generator.dialects import recognized, registry
from thermoplc.pipeline import block_dialect

TEMPLATES = Path(printer.__file__).resolve().parent.parent / "templates"


def _choices(parser: argparse.ArgumentParser, command: str, option: str) -> tuple:
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[command]
    return tuple(next(a for a in sub._actions if option in a.option_strings).choices)


def test_every_reader_of_the_dialects_reads_the_registry():
    names = tuple(registry())
    assert names == ("tia", "step7", "iec")
    assert _choices(build_parser(), "generate", "--dialect") == names
    assert tuple(printer.DIALECTS) == tuple(testbench.TARGETS) == tuple(testbench.ROWS_PER_CYCLE) == names
    assert tuple(testbench_text.SPELLINGS) == names
    for record in registry().values():
        assert (TEMPLATES / record.template).is_file(), record.name


@pytest.mark.parametrize("dialect", tuple(registry()))
def test_a_golden_block_is_recognized_as_its_dialect(dialect):
    path = golden_block("mlr", dialect)
    assert recognized(path.read_text()) == dialect
    assert block_dialect(str(path)) == (dialect, False)
    assert block_dialect(str(golden_block("mlr", "plcopen"))) == ("iec", True)


def test_the_first_dialect_that_recognizes_a_text_wins():
    """TIA's attribute beside a quoted name is TIA, a quoted name alone STEP 7, anything else IEC."""
    assert recognized('FUNCTION_BLOCK "X"\n{ S7_Optimized_Access := \'TRUE\' }') == "tia"
    assert recognized('FUNCTION_BLOCK "X"\nVERSION : \'0.1\'') == "step7"
    assert recognized("FUNCTION_BLOCK X\n") == "iec"
