"""Issue 13: the static range proof at generate. Every golden model is proven; the proven ranges
contain every value the stress replay reaches; hostile coefficients are refused with the statement
that fails; the IR-level rules (recognised Kalman forms, INT counters, divisions) hold."""
import json
import warnings

import pytest

from thermoplc.base.binary32 import f32_hex
from thermoplc.generator.ir import Assign, BinOp, Block, Const, If, IntConst, Ref, Region, Var
from thermoplc.generator.lower import lower, prove
from thermoplc.generator.printer import render
from thermoplc.generator.ranges import prove_ranges
from thermoplc.models.modelfile import load_model
from thermoplc.models.safety import Limits
from thermoplc.verifier.reading.parser import parse_text
from thermoplc.verifier.replays.stress import stress
from tests.cli_runner import thermoplc
from tests.golden_models import GOLDEN

KINDS = sorted(p.stem for p in GOLDEN.glob("*.json"))
WIDE = Limits(max_output=1.0e12, max_step=1.0e12)  # the limits never bind: outputs are the model's values


@pytest.mark.parametrize("kind", KINDS)
def test_every_golden_model_is_proven_and_contains_what_the_stress_replay_reaches(kind):
    model = load_model(GOLDEN / f"{kind}.json")
    block = lower(model, WIDE)
    proof = prove(model, block, WIDE)
    assert proof.problems == ()
    seen = stress(parse_text(render(block, "iec"), "b.st"), model, WIDE, "b.st")
    assert seen.problems == ()
    for name, (low, high) in seen.output_ranges.items():
        proven_low, proven_high = proof.ranges[name]
        assert proven_low <= low and high <= proven_high, (name, (low, high), proof.ranges[name])


def _edited(tmp_path, kind: str, coefficients: dict):
    doc = json.loads((GOLDEN / f"{kind}.json").read_text())
    for name, value in coefficients.items():
        doc["coefficients"][name] = {"f64": value, "f32": f32_hex(value)}
    path = tmp_path / f"{kind}.json"
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("kind, coefficients, statement, what", [
    ("mlr", {"beta_1": 3e37}, "c_beta_1", "overflow to Inf"),
    ("gm0n", {"b_1": 3e37}, "c_b_1", "overflow to Inf"),  # no running sums since issue 37: b_i*T_i only
    ("kalman", {"N_1": 1e-36, "P0_1": 1e-36}, "Gain * P_pred", "subnormal"),
    ("kalman", {"R_1": 3e38}, "Gain := P_pred / (P_pred + c_R_1)", "underflow to 0"),
    ("bpnn", {"w1_1_1": 3e38}, "c_w1_1_1", "overflow to Inf"),
])
def test_hostile_coefficients_are_refused_naming_the_statement(tmp_path, kind, coefficients, statement, what):
    path = _edited(tmp_path, kind, coefficients)
    result = thermoplc("generate", path.name, "-o", "out.scl", cwd=tmp_path, check=None)
    assert result.returncode == 2 and "range proof fails" in result.stderr, result.stdout + result.stderr
    assert statement in result.stderr and what in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "out.scl").exists()


def test_stats_print_the_proven_ranges(tmp_path):
    result = thermoplc("generate", GOLDEN / "kalman.json", "-o", "k.scl", "--stats", cwd=tmp_path, check=None)
    assert result.returncode == 0, result.stderr
    line = next(x for x in result.stdout.splitlines() if x.startswith("range proof:"))
    assert "model values before the limits: E_z_um -" in line
    assert "outputs: E_z_um -78..78" in line  # the clamp from the recording: 1.5 x its 51.9 um


def _block(body, statics=(), temps=(), constants=(), inputs=(Var("x", "REAL"),)):
    return Block("B", "t", (), inputs, (Var("y", "REAL"),), tuple(statics), tuple(temps), tuple(constants),
                 (Region("r", tuple(body)),))


def test_a_division_by_a_range_containing_zero_is_found_and_a_guarded_one_is_not():
    divide = Assign("y", BinOp("/", Ref("c_One"), Ref("x")))
    assert "division by a range containing 0" in prove_ranges(
        _block([divide], constants=[Const("c_One", 1.0)]), {"x": (-1.0, 1.0)}).problems[0]
    guarded = If(((BinOp(">", Ref("x"), Ref("c_Half")), (divide,)),))
    assert prove_ranges(_block([guarded], constants=[Const("c_One", 1.0), Const("c_Half", 0.5)]),
                        {"x": (-1.0, 1.0)}).problems == ()


def test_an_unbounded_counter_is_found_and_a_wrapping_one_is_proven():
    count = Assign("N", BinOp("+", Ref("N"), Ref("c_One")))
    consts = [Const("c_One", 1, type="INT"), Const("c_Last", 99, type="INT")]
    problems = prove_ranges(_block([count], statics=[Var("N", "INT")], constants=consts), {"x": (0.0, 1.0)}).problems
    assert any("INT range" in p for p in problems)
    wrap = If(((BinOp(">", Ref("N"), Ref("c_Last")), (Assign("N", IntConst(0)),)),))
    assert prove_ranges(_block([count, wrap], statics=[Var("N", "INT")], constants=consts),
                        {"x": (0.0, 1.0)}).problems == ()


def test_a_growing_real_state_is_bounded_by_binary32_rounding_or_reported():
    grow = Assign("S", BinOp("+", Ref("S"), Ref("x")))  # stalls where x is below half an ULP of S
    proof = prove_ranges(_block([grow], statics=[Var("S", "REAL")]), {"x": (0.0, 150.0)})
    assert proof.problems == () and 4e9 < proof.ranges["S"][1] < 1e11
    double = Assign("S", BinOp("+", Ref("S"), Ref("S")))
    start = Assign("S", BinOp("+", Ref("S"), Ref("x")))
    problems = prove_ranges(_block([start, double], statics=[Var("S", "REAL")]), {"x": (1.0, 2.0)}).problems
    assert any("overflow to Inf" in p for p in problems)



def test_a_kalman_pole_of_one_is_refused_by_the_proof_without_a_numpy_warning(tmp_path):
    """A_1 = 1 makes the prediction an integrator: the proof reaches +-inf, where numpy warned on stderr."""
    from thermoplc.base.errors import UserError
    from thermoplc.pipeline import generate
    doc = json.loads((GOLDEN / "kalman.json").read_text())
    doc["coefficients"]["A_1"] = {"f64": 1.0, "f32": f32_hex(1.0)}
    (tmp_path / "k.json").write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(UserError, match=r"k\.json: the range proof fails .* can overflow to Inf"):
            generate(load_model(str(tmp_path / "k.json")), "k.json")
