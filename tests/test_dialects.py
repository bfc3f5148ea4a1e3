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


def _help(parser: argparse.ArgumentParser, command: str, option: str) -> str:
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[command]
    return next(a for a in sub._actions if option in a.option_strings or a.dest == option).help


def test_the_options_that_name_dialects_name_them_from_the_records(monkeypatch):
    """A dialect added by its record alone (here IEC's record renamed, with STEP 7's retentive DB and 20 calls per
    cycle) is named by every option whose help lists dialects, and the help says its bench's budget."""
    import dataclasses

    from thermoplc.generator import dialects
    known = registry()
    added = dataclasses.replace(known["iec"], name="plc9", rank=9, retain=False, attributes=True, rows_per_cycle=20,
                                bench=dataclasses.replace(known["iec"].bench, why="9 KiB per array"))
    monkeypatch.setattr(dialects, "registry", lambda: {**known, "plc9": added})
    parser = build_parser()
    assert _choices(parser, "generate", "--dialect")[-1] == "plc9"
    assert "(tia, iec); step7, plc9: the header says" in _help(parser, "generate", "--retain")
    assert "(tia, step7, plc9)" in _help(parser, "generate", "--header-name")
    assert _help(parser, "generate", "--instance-db").startswith("step7: ")
    assert "10 for step7, 20 for plc9, 50 elsewhere" in _help(parser, "testbench", "--rows-per-cycle")
    assert "plc9: 9 KiB per array" in _help(parser, "testbench", "--calls")
    assert "tia, step7, iec, plc9, or PLCopen XML" in _help(parser, "testbench", "block")
