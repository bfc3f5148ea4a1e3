"""Fuzzing (hypothesis): the ST parser, the interpreter and the CSV reader give clear errors, never a
crash or a hang, and text from user data can never change the structure of an emitted program.

The normal suite runs 150 examples per test; the long run sets THERMOPLC_FUZZ_EXAMPLES, e.g.
`THERMOPLC_FUZZ_EXAMPLES=20000 python -m pytest tests/test_fuzz.py` (see README).
"""
import functools
import json
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from tests.golden_models import GOLDEN, golden_block
from thermoplc.base.errors import UserError
from thermoplc.generator.lower import lower
from thermoplc.generator.printer import render
from thermoplc.models.modelfile import load_model
from thermoplc.recordings.table import read_table
from thermoplc.verifier.engines.interpreter import Machine
from thermoplc.verifier.reading.parser import parse_text

EXAMPLES = int(os.environ.get("THERMOPLC_FUZZ_EXAMPLES", "150"))
GOLDEN_TEXT = golden_block("kalman", "tia").read_text()
ST_WORDS = st.sampled_from(["IF", "THEN", "END_IF", ";", ":=", "#x", "(", ")", "REGION", "END_REGION", "VAR", "END_VAR",
                            "1.5", "-", "*", "WHILE", "FOR", "TO", "DO", "END_FOR", "(*", "*)", "//", "\n", "'", '"',
                            "BEGIN", "FUNCTION_BLOCK", "Real", "ARRAY[0..3] OF", "{", "}", "CASE", "ABS(", "EXP("])


@given(st.text(max_size=400))
@settings(max_examples=EXAMPLES, deadline=None)
def test_parser_on_arbitrary_text_raises_only_user_errors(text):
    try:
        parse_text(text, "fuzz.scl")
    except UserError as exc:
        assert str(exc).startswith("fuzz.scl")


@given(st.integers(0, len(GOLDEN_TEXT) - 1), st.lists(ST_WORDS, min_size=1, max_size=6))
@settings(max_examples=EXAMPLES, deadline=None)
def test_parser_and_interpreter_on_mutated_blocks(at, words):
    """A generated block with tokens spliced in: a clear error, or a program that runs a few calls."""
    text = GOLDEN_TEXT[:at] + " ".join(words) + GOLDEN_TEXT[at:]
    try:
        machine = Machine(parse_text(text, "m.scl"), "m.scl")
        columns = {d.name: [20.0, 20.5, 21.0] for d in machine.inputs if d.type.base == "REAL"}
        columns.update({d.name: [False, True, False] for d in machine.inputs if d.type.base == "BOOL"})
        columns.update({d.name: [0, 1, 2] for d in machine.inputs if d.type.base not in ("REAL", "BOOL")})
        machine.replay(columns, 3)
    except UserError as exc:
        assert str(exc).startswith("m.scl")


@given(st.binary(max_size=600))
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_csv_reader_on_arbitrary_bytes_raises_only_user_errors(tmp_path, data):
    path = tmp_path / "fuzz.csv"
    path.write_bytes(data)
    try:
        table = read_table(path)
        assert all(np.isfinite(col).all() for col in table.columns.values())
    except UserError as exc:
        assert str(exc).startswith(str(path))


CELLS = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.text(max_size=6),
                  st.sampled_from(["", "1,5", "1e400", "-0", "0x10", "nan", " 7 "]))


@given(st.lists(st.lists(CELLS, min_size=2, max_size=4), min_size=1, max_size=8), st.sampled_from([",", ";"]))
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_csv_reader_on_structured_junk(tmp_path, rows, delimiter):
    text = delimiter.join(["time_s", "a", "b", "c"][:len(rows[0])]) + "\n" + "\n".join(delimiter.join(r) for r in rows)
    path = tmp_path / "junk.csv"
    path.write_text(text)
    try:
        read_table(path, None)
    except UserError as exc:
        assert str(exc).startswith(str(path))


@pytest.mark.slow
@given(st.text(min_size=1, max_size=60))
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_text_from_user_data_cannot_change_the_program(tmp_path, hostile):
    """Input units land in comments; whatever they hold, the block parses to the same program."""
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["inputs"][0]["unit"] = hostile
    doc["inputs"][1]["unit"] = "degC *) END_VAR VAR_INPUT x : Real; (* " + hostile
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc))
    for dialect in ("tia", "step7", "iec"):
        clean = parse_text(render(lower(load_model(GOLDEN / "mlr.json")), dialect))
        dirty = parse_text(render(lower(load_model(path)), dialect))
        assert dirty.decls == clean.decls and dirty.body == clean.body


TEXT_FIELDS = (("inputs", 0, "unit"), ("inputs", 1, "column"), ("inputs", 1, "unit"), ("target", "column"),
               ("time_column",))  # the target's unit decides whether a K0 output exists: not free text


@functools.lru_cache(maxsize=None)
def _clean_program(kind: str, dialect: str):
    return parse_text(render(lower(load_model(GOLDEN / f"{kind}.json")), dialect))


def _put(doc: dict, path: tuple, value) -> None:
    node = doc
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value


@given(st.sampled_from(["mlr", "lumped", "kalman"]), st.lists(st.text(min_size=1, max_size=40), min_size=6, max_size=6))
@settings(max_examples=max(EXAMPLES // 5, 10), deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_random_text_in_every_user_field_leaves_the_statements_alone(tmp_path, kind, hostile):
    """Every string field a user controls: text fields reach comments and the title and must not change
    a statement or declaration in any dialect; an effect name is refused unless it is the library's."""
    doc = json.loads((GOLDEN / f"{kind}.json").read_text())
    for path, text in zip(TEXT_FIELDS, hostile):
        _put(doc, path, text)
    path = tmp_path / "m.json"
    if kind == "lumped":
        doc["settings"]["effects"] = [*doc["settings"]["effects"], {"name": hostile[-1], "sensor": None}]
        path.write_text(json.dumps(doc))
        try:
            load_model(path)
        except UserError as exc:
            assert "settings.effects" in str(exc)
        else:
            raise AssertionError(f"effect name {hostile[-1]!r} was accepted")
        doc["settings"]["effects"] = doc["settings"]["effects"][:-1]
    path.write_text(json.dumps(doc))
    for dialect in ("tia", "step7", "iec"):
        clean = _clean_program(kind, dialect)
        dirty = parse_text(render(lower(load_model(path)), dialect))
        assert dirty.decls == clean.decls and dirty.body == clean.body and dirty.name == clean.name
