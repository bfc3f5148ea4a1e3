"""thermoplc diff: structure and behaviour, on generated and hand-edited blocks."""
import json
import re

import jsonschema

import numpy as np
import pytest

from tests.golden_models import golden_block, golden_twin_csv
from tests.cli_runner import thermoplc
from tests.test_json_output import schema
from thermoplc.generator.literals import real_literal
from thermoplc.recordings.table import read_table
from thermoplc.verifier.replays.diff import diff_blocks


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    return golden_twin_csv(tmp_path_factory.mktemp("diff"))


def _one_ulp_up(text: str, name: str) -> tuple[str, float, float]:
    match = re.search(rf"({name} : Real := )([-0-9.E]+);", text)
    old = np.float32(match.group(2))
    new = np.nextafter(old, np.float32(np.inf))
    return text.replace(match.group(0), f"{match.group(1)}{real_literal(float(new))};"), float(old), float(new)


def test_one_ulp_constant_change_shows_structurally_and_behaviourally(tmp_path, data):
    old = golden_block("kalman", "tia")
    text, before, after = _one_ulp_up(old.read_text(), "c_beta_1")
    new = tmp_path / "new.scl"
    new.write_text(text)
    d = diff_blocks(str(old), str(new), read_table(data))
    assert [(c.name, c.old, c.new) for c in d.constants] == [("c_beta_1", before, after)]
    assert d.interface == [] and d.statements == []
    assert not d.behaviour_equal
    error = next(b for b in d.behaviour if b.output == "E_z_um")
    assert error.differing_calls > 0 and 0 < error.max_abs < 1e-4
    out = thermoplc("diff", old, new, "--data", data, cwd=tmp_path, check=1).stdout
    assert "c_beta_1: " in out and "relative" in out and "E_z_um: differs in" in out


def test_dialects_and_reformatting_are_not_changes(tmp_path, data):
    tia = golden_block("lumped", "tia")
    edited = tmp_path / "edited.scl"
    edited.write_text("// reviewed by hand\n" + tia.read_text().replace("\t", "  ").replace("IF ", "if ")
                      .replace(" THEN", " then").replace("END_IF;", "end_if; (* checked *)"))
    for other in (golden_block("lumped", "step7"), golden_block("lumped", "iec"), edited):
        out = thermoplc("diff", tia, other, "--data", data, cwd=tmp_path).stdout
        assert "interface: unchanged" in out and "constants: unchanged" in out
        assert "statements: unchanged" in out and "identical, every output bit equal" in out


def test_changed_statement_and_interface_are_named(tmp_path):
    old = golden_block("mlr", "tia")
    text = old.read_text()
    text = text.replace("#Model_1 := #c_beta0 + #c_beta_1", "#Model_1 := #c_beta0 - #c_beta_1")
    text = text.replace("      T_bearing : Real;", "      T_bearing : Real;\n      T_spare : Real;")
    new = tmp_path / "new.scl"
    new.write_text(text)
    d = diff_blocks(str(old), str(new))
    assert d.interface == ["+ input T_spare : REAL"]
    assert d.statements[0] == "~ region 'Regression on temperature rises, eq. 10': 1 statement(s) replaced by 1"
    assert "#c_beta0 - #c_beta_1" in d.statements[2]
    assert thermoplc("diff", old, new, cwd=tmp_path, check=1).returncode == 1


@pytest.mark.parametrize("old_text, new_text, shown", [
    ("Enable : Bool := TRUE;", "Enable : Bool := FALSE;", "Enable: True -> False"),  # an unwired Enable never runs
    ("c_TempMax : Real := 150.0;", "c_TempMax : Real := 1500.0;", "c_TempMax: 150.0 -> 1500.0"),  # a widened guard
    ("c_OneCall : Int := 1;", "c_OneCall : Int := 0;", "c_OneCall: 1 -> 0"),
])
def test_a_change_that_reaches_the_plc_fails_the_diff_with_or_without_data(tmp_path, data, old_text, new_text, shown):
    """Issue 28 items 1-2: the data never excuses a structural change it does not reach."""
    old = golden_block("mlr", "tia")
    text = old.read_text()
    assert text.count(old_text) == 1
    new = tmp_path / "new.scl"
    new.write_text(text.replace(old_text, new_text))
    for extra in ((), ("--data", data)):
        out = thermoplc("diff", old, new, *extra, cwd=tmp_path, check=1).stdout
        assert "constants: 1 changed" in out and shown in out


def test_an_added_statement_the_data_does_not_tell_apart_still_fails_the_diff(tmp_path, data):
    old = golden_block("mlr", "tia")
    text = old.read_text()
    new = tmp_path / "new.scl"
    new.write_text(text.replace("BEGIN\n", "BEGIN\n    ENO := TRUE;\n", 1))
    out = thermoplc("diff", old, new, "--data", data, cwd=tmp_path, check=1).stdout
    assert "statements: changed" in out and "identical, every output bit equal" in out


def test_retain_counts_in_every_dialect_and_literal_spelling_or_name_case_do_not(tmp_path):
    from tests.golden_models import GOLDEN
    blocks = {}
    for dialect in ("iec", "tia"):
        for retain in ((), ("--retain",)):
            name = f"{dialect}{'_retain' if retain else ''}.st"
            thermoplc("generate", GOLDEN / "kalman.json", "--dialect", dialect, *retain, "-o", name, cwd=tmp_path)
            blocks[name] = tmp_path / name
    out = thermoplc("diff", blocks["iec.st"], blocks["iec_retain.st"], cwd=tmp_path, check=1).stdout
    assert "~ RETAIN: (none) -> " in out  # plain IEC declares no other attribute: RETAIN is still compared
    thermoplc("diff", blocks["iec.st"], blocks["tia_retain.st"], cwd=tmp_path, check=1)
    thermoplc("diff", blocks["iec_retain.st"], blocks["tia_retain.st"], cwd=tmp_path)
    text = blocks["iec.st"].read_text()
    spelled = tmp_path / "spelled.st"
    spelled.write_text(text.replace("FUNCTION_BLOCK ThermalComp", "FUNCTION_BLOCK THERMALCOMP", 1)
                       .replace("END_IF;", "END_IF;\n    Init := Init AND 1.0 > 0.0;", 1))
    other = tmp_path / "other.st"
    other.write_text(text.replace("END_IF;", "END_IF;\n    Init := Init AND 1.00 > 0.0E0;", 1))
    thermoplc("diff", spelled, other, cwd=tmp_path)


def test_diff_json_names_an_int_output_by_its_type(tmp_path):
    """An INT output that differs is an INT in `diff --json` (it was called BOOL), counted in calls."""
    block = """FUNCTION_BLOCK Counter
VAR_INPUT k : INT; x : REAL; END_VAR
VAR_OUTPUT n : INT; y : REAL; END_VAR
n := k * {scale};
y := x;
END_FUNCTION_BLOCK
"""
    (tmp_path / "a.st").write_text(block.format(scale="2"))
    (tmp_path / "b.st").write_text(block.format(scale="3"))
    (tmp_path / "d.csv").write_text("time_s,k,x\n" + "".join(f"{k},{k},{k / 4}\n" for k in range(12)))
    thermoplc("diff", "a.st", "b.st", "--data", "d.csv", "--json", "d.json", cwd=tmp_path, check=1)
    document = json.loads((tmp_path / "d.json").read_text())
    jsonschema.validate(document, schema("diff"))
    behaviour = {b["output"]: b for b in document["behaviour"]}
    assert behaviour["n"]["type"] == "INT" and behaviour["n"]["max_abs"] is None
    assert behaviour["n"]["differing_calls"] > 0 and behaviour["y"]["type"] == "REAL"
