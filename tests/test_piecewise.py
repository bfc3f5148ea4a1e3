"""Paper 001's piecewise model library: fit on batches, generate, verify; every table entry matters."""
import re

import pytest

from tests.golden_models import batch_csvs
from tests.cli_runner import thermoplc
from thermoplc.base.binary32 import f32_bits, f32_from_bits
from thermoplc.generator.literals import real_literal
from thermoplc.models.modelfile import load_model
from thermoplc.models.kinds.piecewise import node_of, select
from thermoplc.recordings.table import read_table, write_table
from thermoplc.machines.cascade import simulate
from thermoplc.verifier.replays.replay import verify_against_model


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    folder = tmp_path_factory.mktemp("piecewise")
    batches = batch_csvs(folder)
    args = ["fit", "--model", "piecewise", "--target", "E_z_um", "--temps", "T_motor,T_bearing,T_env",
            "--ambient", "T_env", "--train-until", 21600, "-o", "pw.json"]
    for path in batches:
        args += ["--data", path.name]
    out = thermoplc(*args, cwd=folder).stdout
    assert "fitted piecewise on batch_14C.csv, batch_19C.csv, batch_26C.csv, batch_31C.csv" in out
    thermoplc("generate", "pw.json", "-o", "pw.scl", cwd=folder)
    uses = []
    for ambient in (16.5, 21.0, 27.5):  # each between two nodes: every node gets a non-zero weight
        path = folder / f"use_{ambient:g}.csv"
        path.write_text(write_table(simulate(3, seed=int(ambient * 10), ambient_start=ambient)))
        uses.append(path)
    return folder, uses


def test_nodes_follow_the_5_degree_grid():
    assert [node_of(t) for t in (14.9, 16.4, 19.9, 25.1, 27.2, 30.0, 35.2, -3, 47)] == [15, 15, 20, 25, 25, 30, 35, 0, 40]
    nodes = [15.0, 20.0, 25.0]
    assert [select(nodes, t) for t in (10, 15, 17, 20, 24, 26)] == [(0, 0), (0, 0), (0, 1), (0, 1), (1, 2), (2, 2)]


def test_piecewise_block_verifies_bit_exact(library):
    folder, uses = library
    for use in uses:
        result = thermoplc("verify", "pw.scl", "--model", "pw.json", "--data", use.name, cwd=folder)
        assert "bit-exact" in result.stdout and "NOT" not in result.stdout


def table_mutants(text: str):
    """Every variant of a block with one table entry moved up by one ULP: (entry name, text)."""
    for match in re.finditer(r"(tab_\w+) : Array\[0\.\.\d+\] of Real := \[([^\]]*)\]", text):
        spans = [(m.start(1), m.end(1)) for m in re.finditer(r"\s*([-0-9.E]+)\s*(?:,|$)", match.group(2))]
        offset = match.start(2)
        for k, (start, end) in enumerate(spans):
            value = float(match.group(2)[start:end])
            bumped = real_literal(f32_from_bits(f32_bits(value) + 1))
            yield f"{match.group(1)}[{k}]", text[:offset + start] + bumped + text[offset + end:]


def test_one_ulp_change_of_any_table_entry_is_caught(library):
    folder, uses = library
    model = load_model(folder / "pw.json")
    tables = [read_table(u) for u in uses]
    entries = 0
    for entry, mutant in table_mutants((folder / "pw.scl").read_text()):
        path = folder / "mutant.scl"
        path.write_text(mutant)
        reports = [verify_against_model(str(path), model, str(folder / "pw.json"), t) for t in tables]
        assert not any(r.ok for r in reports), f"{entry} changed by one ULP went unnoticed"
        assert any(r.mismatch is not None for r in reports), f"{entry}: no output changed on any data set"
        entries += 1
    assert entries == 4 * 5  # 4 nodes x (node, beta0, three slopes)
