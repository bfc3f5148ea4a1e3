"""Issue 13: `verify` never says bit-exact wrongly and nothing unsafe reaches the NC. One test per
case found by a hostile review: injection past the parser, values compared by the wrong type,
engines that disagree on integers, integer constants that overflow, NaN through the limiter,
names that collide, a planted native library."""
import json
import subprocess
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from thermoplc.base.binary32 import f32_hex
from thermoplc.base.identifiers import identifier_problem
from thermoplc.recordings.table import write_table
from thermoplc.verifier.reading.parser import StSyntaxError, parse_text
from tests.cli_runner import thermoplc as run_cli
from tests.golden_models import GOLDEN

HERE = Path(__file__).parent
thermoplc = partial(run_cli, check=None)  # every test here reads the exit code itself


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    here = tmp_path_factory.mktemp("never_wrong")
    assert thermoplc("twin", "--hours", 2, "--seed", 5, "-o", "twin.csv", cwd=here).returncode == 0
    return here


def _hostile_model(folder: Path, name: str, edit) -> Path:
    doc = json.loads((GOLDEN / "lumped.json").read_text())
    edit(doc)
    path = folder / name
    path.write_text(json.dumps(doc))
    return path


def test_effect_name_cannot_inject_statements(folder):
    injected = "x' BEGIN E_z_um := 250.0; END_FUNCTION_BLOCK //"
    model = _hostile_model(folder, "inject.json", lambda d: d["settings"]["effects"].append({"name": injected}))
    result = thermoplc("generate", model, "-o", "inject.scl", "--dialect", "step7", cwd=folder)
    assert result.returncode == 2 and "settings.effects" in result.stderr and "Traceback" not in result.stderr
    assert not (folder / "inject.scl").exists()


def test_text_after_a_quoted_title_is_parsed_so_diff_and_verify_see_it(folder):
    clean = (GOLDEN / "mlr.step7.scl").read_text()
    title = next(line for line in clean.splitlines() if line.startswith("TITLE"))
    (folder / "clean.scl").write_text(clean)
    (folder / "hostile.scl").write_text(clean.replace(title, "TITLE = 'x' AUTHOR : evil"))
    result = thermoplc("diff", "clean.scl", "hostile.scl", cwd=folder)
    assert result.returncode == 1, result.stdout + result.stderr
    assert "~ TITLE" in result.stdout and "~ AUTHOR: 'thermopl' -> 'evil' 'thermopl'" in result.stdout
    (folder / "broken.scl").write_text(clean.replace(title, "TITLE = 'x' y := 250.0;"))
    for command in (("diff", "clean.scl", "broken.scl"), ("verify", "broken.scl", "--model", GOLDEN / "mlr.json",
                                                          "--data", "twin.csv")):
        result = thermoplc(*command, cwd=folder)
        assert result.returncode == 2 and "broken.scl:" in result.stderr and "syntax error" in result.stderr


def test_header_attributes_are_compared(folder):
    clean = (GOLDEN / "mlr.step7.scl").read_text()
    (folder / "a.scl").write_text(clean)
    version = next(line for line in clean.splitlines() if line.startswith("VERSION"))
    (folder / "b.scl").write_text(clean.replace(version, "VERSION : '15.15'"))
    result = thermoplc("diff", "a.scl", "b.scl", cwd=folder)
    old = version.split(":", 1)[1].strip()
    assert result.returncode == 1 and f"~ VERSION: '{old.strip(chr(39))}' -> '15.15'" in result.stdout, result.stdout


def test_every_user_string_is_escaped_in_the_title():
    from thermoplc.generator.printer import safe_string
    for text in ("a'b", 'a"b', "a$b", "line\nbreak", "(* x *)", "{ attr }"):
        printed = safe_string(text)
        assert not set(printed) & set("'\"$\n{}") and "(*" not in printed


HAND_WRITTEN = """FUNCTION_BLOCK Counter
VAR_INPUT x : INT; END_VAR
VAR_OUTPUT i : DINT; flag : BOOL; END_VAR
i := x + x;
flag := x > 0;
END_FUNCTION_BLOCK
"""


def _trace(folder: Path, name: str, columns: dict) -> None:
    (folder / name).write_text(write_table({"time_s": np.arange(len(next(iter(columns.values())))) * 10.0, **columns}))


def test_integer_outputs_are_compared_by_value_not_as_booleans(folder):
    (folder / "counter.st").write_text(HAND_WRITTEN)
    _trace(folder, "right.csv", {"x": np.array([1.0, 2.0, 3.0]), "i_plc": np.array([2.0, 4.0, 6.0])})
    ok = thermoplc("verify", "counter.st", "--data", "right.csv", "--expect", "i=i_plc", cwd=folder)
    assert ok.returncode == 0 and "bit-exact" in ok.stdout, ok.stdout + ok.stderr
    _trace(folder, "wrong.csv", {"x": np.array([1.0, 2.0, 3.0]), "i_plc": np.array([2.0, 5.0, 6.0])})
    bad = thermoplc("verify", "counter.st", "--data", "wrong.csv", "--expect", "i=i_plc", cwd=folder)
    assert bad.returncode == 1 and "NOT bit-exact" in bad.stdout and "first divergent cycle 1" in bad.stdout


def test_cells_a_type_cannot_hold_are_errors_with_their_line(folder):
    (folder / "counter.st").write_text(HAND_WRITTEN)
    _trace(folder, "half.csv", {"x": np.array([1.0, 2.5]), "i_plc": np.array([2.0, 5.0])})
    result = thermoplc("verify", "counter.st", "--data", "half.csv", "--expect", "i=i_plc", cwd=folder)
    assert result.returncode == 2 and "line 3, column 'x'" in result.stderr and "whole number" in result.stderr
    _trace(folder, "flag.csv", {"x": np.array([1.0, 2.0]), "f_plc": np.array([1.0, 2.0])})
    result = thermoplc("verify", "counter.st", "--data", "flag.csv", "--expect", "flag=f_plc", cwd=folder)
    assert result.returncode == 2 and "column 'f_plc'" in result.stderr and "0 or 1" in result.stderr


OVERFLOW = """FUNCTION_BLOCK Over
VAR_INPUT j : DINT; k : DINT; END_VAR
VAR_OUTPUT y : REAL; END_VAR
VAR CONSTANT c_one : REAL := 1.0; END_VAR
IF j * k * j > 0 THEN
    y := c_one;
END_IF;
END_FUNCTION_BLOCK
"""


@pytest.mark.parametrize("engine", ["interp", "auto"])
def test_integer_overflow_fails_verify_in_both_engines(folder, engine):
    (folder / "over.st").write_text(OVERFLOW)
    _trace(folder, "big.csv", {"j": np.array([1.0, 2.0e9]), "k": np.array([1.0, 2.0e9]), "y_plc": np.array([1.0, 1.0])})
    result = thermoplc("verify", "over.st", "--data", "big.csv", "--expect", "y=y_plc", "--engine", engine, cwd=folder)
    assert result.returncode == 1, result.stdout + result.stderr
    assert "UNSAFE" in result.stdout and "INT overflow" in result.stdout and "from cycle 1" in result.stdout


def test_an_integer_literal_beyond_dint_is_a_syntax_error():
    text = "FUNCTION_BLOCK B\nVAR x : DINT; END_VAR\nx := 12345678901234567890123456;\nEND_FUNCTION_BLOCK\n"
    with pytest.raises(StSyntaxError, match=r"<text>:3:6: integer literal 12345678901234567890123456 does not fit DINT"):
        parse_text(text, "<text>")


def test_ring_buffer_beyond_int_is_refused_at_fit_and_generate(folder):
    fit = thermoplc("fit", "--data", "twin.csv", "--model", "dlag", "--target", "E_z_um", "--temps", "T_motor",
                    "--lags", 1, "--lag-step", 330000, "--train-until", 3600, "-o", "long.json", cwd=folder)
    assert fit.returncode == 2 and "at most 32767" in fit.stderr and not (folder / "long.json").exists()
    doc = json.loads((GOLDEN / "dlag.json").read_text())
    doc["settings"]["lag_step_samples"] = 33000
    (folder / "dlag_long.json").write_text(json.dumps(doc))
    result = thermoplc("generate", "dlag_long.json", "-o", "dlag_long.scl", cwd=folder)
    assert result.returncode == 2 and "does not fit INT" in result.stderr and not (folder / "dlag_long.scl").exists()


def test_kalman_without_noise_is_refused(folder):
    doc = json.loads((GOLDEN / "kalman.json").read_text())
    for name in ("N_1", "R_1", "P0_1"):
        doc["coefficients"][name] = {"f64": 0.0, "f32": "0x00000000"}
    (folder / "quiet.json").write_text(json.dumps(doc))
    result = thermoplc("generate", "quiet.json", "-o", "quiet.scl", cwd=folder)
    assert result.returncode == 2 and "needs it > 0" in result.stderr and not (folder / "quiet.scl").exists()


def test_nan_never_reaches_the_nc_and_fails_verify(folder):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    for name, value in (("beta_1", 3e38), ("beta_2", -3e38)):  # a few kelvin of rise overflow to Inf, Inf - Inf
        doc["coefficients"][name] = {"f64": value, "f32": f32_hex(value)}
    (folder / "huge.json").write_text(json.dumps(doc))
    refused = thermoplc("generate", "huge.json", "-o", "huge.scl", cwd=folder)
    assert refused.returncode == 2 and "range proof fails" in refused.stderr and "Inf" in refused.stderr
    assert not (folder / "huge.scl").exists()
    from thermoplc.generator.lower import lower
    from thermoplc.generator.printer import render
    from thermoplc.models.modelfile import load_model
    (folder / "huge.scl").write_text(render(lower(load_model(folder / "huge.json")), "tia"))  # past generate's check
    result = thermoplc("verify", "huge.scl", "--model", "huge.json", "--data", "twin.csv", cwd=folder)
    assert result.returncode == 1 and "UNSAFE" in result.stdout, result.stdout + result.stderr
    from thermoplc.models.reference import block_outputs, model_inputs
    from thermoplc.models.safety import INVALID, Limits, k0_key
    from thermoplc.recordings.table import read_table
    model = load_model(folder / "huge.json")
    out = block_outputs(model, model_inputs(model, read_table(folder / "twin.csv")), "f32", Limits())
    assert np.isfinite(out["E_z_um"]).all() and np.isfinite(out[k0_key(1)]).all() and out[INVALID].any()


@pytest.mark.parametrize("name", ["Init", "Ready", "K0_1", "Invalid", "METHOD", "POINTER", "INTERFACE", "REF_TO",
                                  "OK", "TIMER", "UNION", "M10", "DBW4"])
def test_names_that_collide_are_refused(folder, name):
    table = (folder / "twin.csv").read_text().replace("T_motor", name, 1)
    (folder / f"named_{name}.csv").write_text(table)
    result = thermoplc("fit", "--data", f"named_{name}.csv", "--model", "mlr", "--target", "E_z_um", "--temps", name,
                       "-o", f"named_{name}.json", cwd=folder)
    if result.returncode == 0:
        result = thermoplc("generate", f"named_{name}.json", "-o", f"named_{name}.scl", cwd=folder)
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stdout + result.stderr
    assert not (folder / f"named_{name}.scl").exists()


def test_reserved_words_are_checked_case_insensitively():
    for word in ("method", "Pointer", "end_region", "Timer", "ok", "dbw12", "m7"):
        assert identifier_problem(word), word
    for fine in ("T_motor", "Mass1", "Db_offset", "M_1"):
        assert identifier_problem(fine) is None, fine


PLANTED = r"""
#include <stdio.h>
__attribute__((constructor)) static void planted(void) {
    FILE *f = fopen(getenv("PLANTED_MARKER"), "w"); if (f) { fputs("ran", f); fclose(f); }
}
"""


def test_a_planted_library_is_never_loaded(folder, tmp_path):
    cache = tmp_path / "cache" / "thermoplc" / "native"
    cache.mkdir(parents=True)
    cache.chmod(0o700)  # private, as the cache asks: else it is not used at all
    source = tmp_path / "planted.c"
    source.write_text("#include <stdlib.h>\n" + PLANTED)
    build = subprocess.run(["gcc", "-shared", "-fPIC", "-o", str(tmp_path / "planted.so"), str(source)],
                           capture_output=True)
    if build.returncode != 0:
        pytest.skip("no C compiler")
    marker = tmp_path / "marker"
    env = {"XDG_CACHE_HOME": str(tmp_path / "cache"), "PLANTED_MARKER": str(marker), "TMPDIR": str(tmp_path)}
    (folder / "counter.st").write_text(HAND_WRITTEN)
    _trace(folder, "right.csv", {"x": np.array([1.0, 2.0, 3.0]), "i_plc": np.array([2.0, 4.0, 6.0])})
    verify = ("verify", "counter.st", "--data", "right.csv", "--expect", "i=i_plc", "--engine", "fast")
    assert thermoplc(*verify, cwd=folder, env=env).returncode == 0
    entries = list(cache.glob("*.so"))
    assert entries, "the first verify caches the block"
    for entry in entries:  # the cached block's own name, so the planted library is what a load would open
        entry.write_bytes((tmp_path / "planted.so").read_bytes())
    result = thermoplc(*verify, cwd=folder, env=env)
    assert result.returncode == 0, result.stdout + result.stderr
    assert not marker.exists()
    assert not list(tmp_path.glob("thermoplc-native-*")), "the build folder is removed after loading"


def test_a_failed_compile_leaves_nothing(folder, tmp_path):
    (folder / "counter.st").write_text(HAND_WRITTEN)
    _trace(folder, "right.csv", {"x": np.array([1.0, 2.0, 3.0]), "i_plc": np.array([2.0, 4.0, 6.0])})
    result = thermoplc("verify", "counter.st", "--data", "right.csv", "--expect", "i=i_plc", "--engine", "fast",
                       cwd=folder, env={"CC": "false", "TMPDIR": str(tmp_path)})
    assert result.returncode == 2 and "failed (exit 1)" in result.stderr, result.stdout + result.stderr
    assert not list(tmp_path.iterdir())


FOR_OVERFLOW = """FUNCTION_BLOCK Blk
VAR_INPUT n : DINT; END_VAR
VAR_OUTPUT Cnt : DINT; END_VAR
VAR i : INT; s : DINT; END_VAR
s := 0;
FOR i := 32760 TO 32767 DO
  s := s + 1;
END_FOR;
Cnt := s + n;
END_FUNCTION_BLOCK
"""
NO_INPUTS = """FUNCTION_BLOCK Blk
VAR_OUTPUT Out : REAL; END_VAR
VAR CONSTANT c1 : REAL := 1.0; END_VAR
Out := Out + c1;
END_FUNCTION_BLOCK
"""


def test_a_for_counter_that_wraps_is_an_overflow(folder):
    (folder / "forov.st").write_text(FOR_OVERFLOW)
    _trace(folder, "fo.csv", {"n": np.array([1.0, 2.0]), "c": np.array([9.0, 10.0])})
    result = thermoplc("verify", "forov.st", "--data", "fo.csv", "--expect", "Cnt=c", cwd=folder)
    assert result.returncode == 1 and "INT overflow (value 32768 outside INT)" in result.stdout


def test_a_block_without_inputs_replays_every_row(folder):
    (folder / "noin.st").write_text(NO_INPUTS)
    _trace(folder, "no.csv", {"x": np.array([1.0, 2.0, 4.0])})
    result = thermoplc("verify", "noin.st", "--data", "no.csv", "--expect", "Out=x", cwd=folder)
    assert result.returncode == 1 and "first divergent cycle 2" in result.stdout, result.stdout + result.stderr


@pytest.mark.parametrize("declaration, message", [
    ("k : INT := 40000;", "k is INT but starts at 40000"), ("k : DINT := 2.5;", "k is DINT but starts at 2.5"),
    ("k : BOOL := 256;", "k is BOOL but starts at 256"), ("k : REAL := 1.0E39;", "beyond the largest REAL")])
def test_start_values_the_type_cannot_hold_are_errors(folder, declaration, message):
    (folder / "init.st").write_text(NO_INPUTS.replace("VAR CONSTANT", f"VAR {declaration} END_VAR\nVAR CONSTANT"))
    _trace(folder, "no.csv", {"x": np.array([1.0, 2.0, 3.0])})
    result = thermoplc("verify", "init.st", "--data", "no.csv", "--expect", "Out=x", cwd=folder)
    assert result.returncode == 2 and message in result.stderr, result.stderr


def test_an_scl_escaped_quote_does_not_end_the_title(folder):
    block = "FUNCTION_BLOCK Blk\nTITLE = 'Compensation$' (* '\n" + NO_INPUTS.split("\n", 1)[1].replace(
        "Out := Out + c1;", "Out := Out + c1;\n// *)\nOut := Out + c1;")
    (folder / "esc.st").write_text(block)
    program = parse_text(block, "esc.st")
    assert len(program.body) == 2 and program.header[0] == ("TITLE", "'Compensation$' (* '")


def test_an_output_declared_with_another_type_than_the_models_is_refused(folder):
    text = (GOLDEN / "mlr.tia.scl").read_text().replace("K0_1 : Real;", "K0_1 : DInt;")
    text = "\n".join(line for line in text.splitlines() if not line.strip().startswith("#K0_1 :="))  # never written
    (folder / "k0dint.scl").write_text(text)
    result = thermoplc("verify", "k0dint.scl", "--model", GOLDEN / "mlr.json", "--data", "twin.csv", cwd=folder)
    assert result.returncode == 2 and "K0_1 is declared DINT; the model's block has it as REAL" in result.stderr


@pytest.mark.parametrize("argv, message", [
    (("--expect", "Out=x,Out=y"), "names output 'Out' twice"), (("--expect", "Out=x", "--inputs", "bogus=x"), "--inputs maps bogus")])
def test_ambiguous_mappings_are_refused(folder, argv, message):
    (folder / "noin.st").write_text(NO_INPUTS)
    _trace(folder, "two.csv", {"x": np.array([1.0, 2.0]), "y": np.array([1.0, 2.0])})
    result = thermoplc("verify", "noin.st", "--data", "two.csv", *argv, cwd=folder)
    assert result.returncode == 2 and message in result.stderr, result.stderr


def test_diff_compares_integer_outputs_by_value_and_names_without_case(folder):
    old = "FUNCTION_BLOCK B\nVAR_INPUT n : DINT; END_VAR\nVAR_OUTPUT Cnt : DINT; END_VAR\nCnt := n + n;\nEND_FUNCTION_BLOCK\n"
    (folder / "old.st").write_text(old)
    (folder / "new.st").write_text(old.replace("n + n", "n * n"))
    (folder / "case.st").write_text(old.replace("Cnt", "CNT"))
    _trace(folder, "n.csv", {"n": np.array([2.0, 3.0])})
    changed = thermoplc("diff", "old.st", "new.st", "--data", "n.csv", cwd=folder)
    assert changed.returncode == 1 and "Cnt: differs in 1 calls" in changed.stdout, changed.stdout
    same = thermoplc("diff", "old.st", "case.st", "--data", "n.csv", cwd=folder)
    assert same.returncode == 0, same.stdout


REGIONS = """FUNCTION_BLOCK B
VAR_INPUT a : REAL; END_VAR
VAR_OUTPUT y : REAL; END_VAR
VAR x : REAL := 1.0; END_VAR
REGION A
  x := x + a;
END_REGION
REGION B
  y := x;
END_REGION
END_FUNCTION_BLOCK
"""


def test_structure_diff_sees_reordered_regions_and_changed_start_values(folder):
    (folder / "r_old.st").write_text(REGIONS)
    order = REGIONS.replace("REGION A\n  x := x + a;\nEND_REGION\n", "").replace("END_REGION\nEND_FUNCTION",
                                                                              "END_REGION\nREGION A\n  x := x + a;\nEND_REGION\nEND_FUNCTION")
    (folder / "r_order.st").write_text(order)
    (folder / "r_init.st").write_text(REGIONS.replace("x : REAL := 1.0;", "x : REAL := 1000.0;"))
    reordered = thermoplc("diff", "r_old.st", "r_order.st", cwd=folder)
    assert reordered.returncode == 1 and "regions reordered: B | A" in reordered.stdout, reordered.stdout
    started = thermoplc("diff", "r_old.st", "r_init.st", cwd=folder)
    assert started.returncode == 1 and "x: 1.0 -> 1000.0" in started.stdout, started.stdout


def test_fit_refuses_a_column_named_like_the_blocks_own_variable(folder):
    (folder / "ready.csv").write_text((folder / "twin.csv").read_text().replace("T_motor", "Ready", 1))
    result = thermoplc("fit", "--data", "ready.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "Ready",
                       "--train-until", 3600, "-o", "ready.json", cwd=folder)
    assert result.returncode == 2 and "'Ready' and 'Ready' are the same identifier" in result.stderr
    assert not (folder / "ready.json").exists()


def test_finding_counts_are_not_doubled_by_the_mismatch_report(folder):
    block = NO_INPUTS.replace("VAR CONSTANT c1 : REAL := 1.0; END_VAR", "VAR CONSTANT c1 : REAL := 1.0; c0 : REAL := 0.0; END_VAR"
                              ).replace("Out := Out + c1;", "Out := Out + c1;\nOut := Out + c1 / c0 - c1 / c0;")
    (folder / "nan.st").write_text(block)
    _trace(folder, "n4.csv", {"x": np.array([1.0, 2.0, 3.0, 4.0])})
    result = thermoplc("verify", "nan.st", "--data", "n4.csv", "--expect", "Out=x", "--engine", "interp", cwd=folder)
    assert result.returncode == 1 and "4 time(s) from cycle 0" in result.stdout and "8 time(s)" not in result.stdout, \
        result.stdout


def test_a_subnormal_constant_is_refused_at_generate_and_fails_verify(folder):
    """Issue 28 item 3: a PLC that flushes subnormals to zero computes with 0 where the model has 1e-40."""
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["coefficients"]["beta_1"] = {"f64": 1e-40, "f32": f32_hex(1e-40)}
    (folder / "tiny.json").write_text(json.dumps(doc))
    refused = thermoplc("generate", "tiny.json", "-o", "tiny.scl", cwd=folder)
    assert refused.returncode == 2 and "constant c_beta_1 = 9.99994610111476e-41 is subnormal" in refused.stderr
    assert not (folder / "tiny.scl").exists()
    thermoplc("generate", GOLDEN / "mlr.json", "-o", "plain.scl", "--force", cwd=folder)
    text = (folder / "plain.scl").read_text()
    start = text.index("c_beta_1 : Real := ")
    (folder / "tiny.scl").write_text(text[:start] + "c_beta_1 : Real := 1.0E-40" + text[text.index(";", start):])
    result = thermoplc("verify", "tiny.scl", "--model", "tiny.json", "--data", "twin.csv", cwd=folder)
    assert result.returncode == 1 and result.stdout.startswith("NOT verified")
    assert "c_beta_1 is declared with the subnormal value 9.99994610111476e-41" in result.stdout


def test_a_block_that_fails_at_run_time_is_not_its_model(folder):
    """Issue 27 review: c_K_1, a Bayes block's index stride into tab_Pred, edited to 9 sends the index
    outside the table; that is a block that differs from its model (exit 1, the interpreter's message
    kept), not a bad input (exit 2), with --model, with --faults and with a recorded trace."""
    from tests.golden_models import golden_block, golden_twin_csv
    text = golden_block("bayes", "tia").read_text()
    assert text.count("c_K_1 : Int := 8;") == 1
    (folder / "k.scl").write_text(text.replace("c_K_1 : Int := 8;", "c_K_1 : Int := 9;"))
    data = golden_twin_csv(folder)
    index = "k.scl:370:22: index 69 outside tab_Pred[0..63] at cycle 388"
    for extra in ((), ("--faults",), ("--engine", "interp")):
        result = thermoplc("verify", "k.scl", "--model", GOLDEN / "bayes.json", "--data", data, *extra, cwd=folder)
        assert result.returncode == 1 and index in result.stdout and not result.stderr, result.stdout + result.stderr
    plain = thermoplc("verify", "k.scl", "--model", GOLDEN / "bayes.json", "--data", data, cwd=folder)
    assert plain.stdout.startswith("NOT bit-exact: k.scl stops with a run-time error on golden_twin.csv")
    assert "c_K_1: block 9, model 8" in plain.stdout
    (folder / "div.st").write_text("FUNCTION_BLOCK D\nVAR_INPUT x : INT; END_VAR\nVAR_OUTPUT y : INT; END_VAR\n"
                                   "y := 10 / x;\nEND_FUNCTION_BLOCK\n")
    _trace(folder, "div.csv", {"x": np.array([1.0, 0.0]), "y_plc": np.array([10.0, 0.0])})
    trace = thermoplc("verify", "div.st", "--data", "div.csv", "--expect", "y=y_plc", cwd=folder)
    assert trace.returncode == 1 and "div.st:4:6: integer division by zero at cycle 1" in trace.stdout, \
        trace.stdout + trace.stderr
