"""The interpreter rounds like numpy float32, operation by operation, and reports what it meets."""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from thermoplc.base.binary32 import f32_bits, f32_from_bits
from thermoplc.generator import ir
from thermoplc.generator.literals import real_literal
from thermoplc.generator.printer import DIALECTS, _Printer
from thermoplc.verifier.engines.interpreter import InterpretError, Machine
from thermoplc.verifier.reading.parser import parse_text
from tests.strategies import CONSTANTS, VARIABLES, real_exprs

any_f32 = st.integers(0, 2 ** 32 - 1).map(f32_from_bits)
finite_f32 = any_f32.filter(math.isfinite)


def numpy_eval(e, env):
    """Independent float32 evaluation of an IR tree with numpy scalars."""
    if isinstance(e, ir.Ref):
        return env[e.name]
    if isinstance(e, ir.Unary):
        return -numpy_eval(e.operand, env)
    if isinstance(e, ir.Call):
        args = [numpy_eval(a, env) for a in e.args]
        if e.func == "ABS":
            return np.abs(args[0])
        if e.func == "SQRT":
            return np.sqrt(args[0])
        a, b = args
        if e.func == "MIN":
            return b if b < a else a
        return b if b > a else a
    a, b = numpy_eval(e.left, env), numpy_eval(e.right, env)
    return {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide}[e.op](a, b)


def block_for(expr, constants):
    printer = _Printer(DIALECTS["tia"])
    decls = "\n".join(f"  {n} : Real;" for n in VARIABLES)
    consts = "\n".join(f"  {n} : Real := {real_literal(v)};" for n, v in constants.items())
    return (f"FUNCTION_BLOCK \"B\"\nVAR_INPUT\n{decls}\nEND_VAR\nVAR_OUTPUT\n  y : Real;\nEND_VAR\n"
            f"VAR CONSTANT\n{consts}\nEND_VAR\nBEGIN\n  #y := {printer.expr(expr)};\nEND_FUNCTION_BLOCK\n")


@given(real_exprs(), st.lists(any_f32, min_size=3, max_size=3), st.lists(finite_f32, min_size=2, max_size=2))
@settings(max_examples=400, deadline=None)
def test_interpreter_matches_numpy_float32(expr, inputs, constants):
    consts = dict(zip(CONSTANTS, constants))
    machine = Machine(parse_text(block_for(expr, consts)))
    machine.call(dict(zip(VARIABLES, inputs)))
    got = machine.values[machine.slots["Y"]]
    env = {n: np.float32(v) for n, v in {**dict(zip(VARIABLES, inputs)), **consts}.items()}
    with np.errstate(all="ignore"):
        want = numpy_eval(expr, env)
    assert isinstance(want, np.float32)
    if math.isnan(want):
        assert math.isnan(got)
    else:
        assert f32_bits(got) == int(want.view(np.uint32))


def run(body: str, decls: str = "", inputs=None, calls: int = 1) -> Machine:
    text = f"FUNCTION_BLOCK \"B\"\n{decls}\nBEGIN\n{body}\nEND_FUNCTION_BLOCK\n"
    machine = Machine(parse_text(text, "b.scl"), "b.scl")
    for _ in range(calls):
        machine.call(inputs or {})
    return machine


def test_state_persists_between_calls_and_temps_do_not():
    m = run("#n := #n + 1; #t := #n; #x := #x + #c;", "VAR n : Int; x : Real; END_VAR VAR_TEMP t : Int; END_VAR "
            "VAR CONSTANT c : Real := 0.1; END_VAR", calls=3)
    assert m.snapshot()["n"] == 3
    assert f32_bits(m.snapshot()["x"]) == int((np.float32(0.1) + np.float32(0.1) + np.float32(0.1)).view(np.uint32))


def test_reading_a_temp_before_writing_it_is_an_error():
    with pytest.raises(InterpretError, match=r"b.scl:5:7: VAR_TEMP t is read before it is written"):
        run("#x := #t;", "VAR x : Real; END_VAR\nVAR_TEMP t : Real; END_VAR")


def test_arrays_and_for_loops():
    m = run("#s := 0.0;\nFOR #i := 0 TO 2 DO #s := #s + #a[#i]; END_FOR;",
            "VAR a : Array[0..2] of Real := [1.0, 2.0, 4.0]; s : Real; i : Int; END_VAR")
    assert m.snapshot()["s"] == 7.0
    with pytest.raises(InterpretError, match="index 3 outside a"):
        run("#s := #a[3];", "VAR a : Array[0..2] of Real; s : Real; END_VAR")


def test_findings_subnormal_nan_inf_non_portable_and_literals():
    m = run("#s := #tiny * #tiny; #n := #z / #z; #i := #one / #z; #e := EXP(#one); #l := #one * 2.0;",
            "VAR s, n, i, e, l : Real; END_VAR VAR CONSTANT tiny : Real := 1.0E-20; z : Real := 0.0; "
            "one : Real := 1.0; END_VAR")
    kinds = {f.kind for f in m.findings.values()}
    assert kinds == {"subnormal", "nan", "inf", "non-portable", "literal"}
    assert f32_bits(m.snapshot()["s"]) == int((np.float32(1e-20) * np.float32(1e-20)).view(np.uint32))


def test_type_errors_name_the_place():
    with pytest.raises(InterpretError, match=r"b.scl:4:\d+: '\+' mixes REAL and INT"):
        run("#x := #x + #i;", "VAR x : Real; i : Int; END_VAR")
    with pytest.raises(InterpretError, match="call of FOO is not supported"):
        run("#x := FOO(#x);", "VAR x : Real; END_VAR")
    with pytest.raises(InterpretError, match="assignment to constant"):
        run("#c := 1.0;", "VAR CONSTANT c : Real := 0.0; END_VAR")


def test_runaway_loop_is_bounded(monkeypatch):
    monkeypatch.setattr("thermoplc.verifier.engines.interpreter.MAX_LOOP_ITERATIONS", 100)
    with pytest.raises(InterpretError, match="exceed 100 iterations"):
        run("FOR #i := 0 TO 1000 DO #i := #i; END_FOR;", "VAR i : DInt; END_VAR")


@pytest.mark.parametrize("engine", ["interp", "fast"])
def test_an_int_intermediate_beyond_int_is_an_overflow_on_both_engines(tmp_path, engine):
    """TIA SCL computes INT with INT in 16 bits, CODESYS in 32: `(n * 2000 + 2000) / 2000` is 18 on one PLC and
    an overflow on the other from n = 17, so the verifier reports it where the intermediate leaves INT. With a
    DINT operand the same expression is computed in 32 bits everywhere and is no overflow."""
    from tests.cli_runner import thermoplc
    for declared, overflow in (("INT", True), ("DINT", False)):
        (tmp_path / "b.st").write_text(
            "FUNCTION_BLOCK B\nVAR_INPUT\n    x : REAL;\nEND_VAR\nVAR_OUTPUT\n    y : REAL;\nEND_VAR\n"
            f"VAR\n    n : {declared};\nEND_VAR\n    n := (n * 2000 + 2000) / 2000;\n    y := x;\nEND_FUNCTION_BLOCK\n")
        rows = ["time_s,x,y_plc"] + [f"{10 * k},{k}.5,{k}.5" for k in range(40)]
        (tmp_path / "t.csv").write_text("\n".join(rows) + "\n")
        result = thermoplc("verify", "b.st", "--data", "t.csv", "--expect", "y=y_plc", "--engine", engine,
                           cwd=tmp_path, check=None)
        if overflow:
            assert result.returncode == 1 and "UNSAFE" in result.stdout and "outside INT" in result.stdout, \
                result.stdout + result.stderr
        else:
            assert result.returncode == 0 and "INT overflow: none" in result.stdout, result.stdout + result.stderr
