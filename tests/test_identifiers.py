"""Recorded column names become block identifiers: the column itself when it is a safe ST name,
else a name derived from it and stated (issue 28: a T1..T16 export needs no renaming by hand)."""
from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from thermoplc.base.errors import UserError
from thermoplc.base.identifiers import MAX_LENGTH, block_identifier, identifier_problem, renaming_note


@pytest.mark.parametrize("column", [f"T{i}" for i in range(1, 17)])
def test_a_common_export_maps_timer_addresses_to_inputs(column):
    assert identifier_problem(column)  # T1..T16 are S7 timers
    assert block_identifier(column, "temperature") == f"{column}_in"
    assert renaming_note(column, f"{column}_in") == (
        f"column {column!r} is block name {column}_in ({column!r} reads as an absolute address (like M10 or DBW4) "
        "in Siemens SCL)")


@pytest.mark.parametrize("column, role, name", [
    ("T_motor", "temperature", "T_motor"), ("TIME", "target", "TIME_out"), ("TON", "speed", "TON_in"),
    ("1st", "ambient", "in_1st"), ("#T1", "temperature", "T1_in"), ("E z [um]", "target", "E_z_um"),
    ("---", "target", "out_target"), ("", "tool length", "in_tool_length")])
def test_each_rule(column, role, name):
    assert block_identifier(column, role) == name
    assert (renaming_note(column, name) is None) == (column == name)


def test_long_columns_are_cut_with_a_digest_so_they_stay_apart():
    a, b = "spindle_bearing_front_temperature_a", "spindle_bearing_front_temperature_b"
    names = block_identifier(a, "temperature"), block_identifier(b, "temperature")
    assert names[0] != names[1] and all(len(n) <= MAX_LENGTH and identifier_problem(n) is None for n in names)


@settings(max_examples=400, deadline=None)
@given(st.text(max_size=80), st.sampled_from(["temperature", "speed", "ambient", "target", "tool length", "feed"]))
def test_any_column_gives_a_safe_name_or_a_clear_refusal(column, role):
    try:
        name = block_identifier(column, role)
    except UserError as error:
        assert "rename the column" in str(error)
        return
    assert identifier_problem(name) is None
    assert block_identifier(column, role) == name  # deterministic


def test_columns_that_map_to_one_name_are_refused_naming_both(tmp_path):
    from tests.cli_runner import thermoplc
    rows = ["time_s,T1,T1_in,E"] + [f"{10 * k},{20 + k / 100},{21 + k / 90},{k / 50}" for k in range(300)]
    (tmp_path / "d.csv").write_text("\n".join(rows) + "\n")
    result = thermoplc("fit", "--data", "d.csv", "--model", "mlr", "--temps", "T1,T1_in", "--target", "E",
                       "--train-rows", "200", "-o", "m.json", cwd=tmp_path, check=2)
    assert "columns 'T1' and 'T1_in' become the same block name" in result.stderr
    assert not (tmp_path / "m.json").exists()
