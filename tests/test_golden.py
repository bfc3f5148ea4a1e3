"""Golden blocks: the generator's output for the committed model files, byte for byte.

After an intended generator change run `python scripts/regen_golden.py` and review the diff.
"""
from pathlib import Path

import pytest

from scripts.regen_golden import DIALECTS, KINDS, golden_twin_csv
from thermoplc.generator.lower import lower
from thermoplc.generator.printer import render
from thermoplc.models.modelfile import load_model
from thermoplc.models.table import read_table
from thermoplc.verifier.replay import verify_against_model

GOLDEN = Path(__file__).parent / "golden"


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("dialect", DIALECTS)
def test_generator_output_matches_golden_file(kind, dialect):
    model = load_model(GOLDEN / f"{kind}.json")
    expected = (GOLDEN / f"{kind}.{dialect}.scl").read_text()
    assert render(lower(model), dialect) == expected


@pytest.mark.parametrize("kind", KINDS)
def test_golden_blocks_verify_bit_exact(kind, tmp_path):
    table = read_table(golden_twin_csv(tmp_path))
    model_path = GOLDEN / f"{kind}.json"
    report = verify_against_model(str(GOLDEN / f"{kind}.tia.scl"), load_model(model_path), str(model_path), table)
    assert report.ok, report.text()
    assert report.cycles == table.rows
