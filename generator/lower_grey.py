"""Grey-model blocks of paper 003: GM(0,N) and GM(1,N) on accumulated temperatures."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, Block, BoolConst, Const, If, Ref, Region, Unary, Var
from thermoplc.models.modelfile import Model
from thermoplc.generator.lower_shared import INIT, const, error_output, header, inputs_of, sum_of


def _grey_block(model: Model, title: str, statics, temps_, constants, regions) -> Block:
    temps = model.signals("temperature")
    return Block(
        name=model.block_name, title=title, header=header(model),
        inputs=inputs_of(temps),
        outputs=(error_output(model),),
        statics=tuple(Var(f"S_{i}", "REAL", f"1-AGO running sum of {s.name}") for i, s in enumerate(temps, start=1))
        + tuple(statics),
        temps=tuple(temps_), constants=tuple(constants), regions=tuple(regions))


def _accumulate(model: Model) -> Region:
    temps = model.signals("temperature")
    return Region("1-AGO: accumulate the temperatures", tuple(
        Assign(f"S_{i}", BinOp("+", Ref(f"S_{i}"), Ref(s.name))) for i, s in enumerate(temps, start=1)))


def lower_gm0n(model: Model) -> Block:
    """The GM(0,N) block: running sums of the temperatures, output the first difference of a + sum b_i*S_i
    (X1 at the first call)."""
    temps = model.signals("temperature")
    level = sum_of([const("a")] + [BinOp("*", const(f"b_{i}"), Ref(f"S_{i}")) for i in range(1, len(temps) + 1)])
    return _grey_block(
        model, "Thermal compensation: grey model GM(0,N) (paper 003)",
        statics=[INIT,
                 Var("Xprev", "REAL", "accumulated error estimate of the previous call")],
        temps_=[Var("X", "REAL", "accumulated error estimate")],
        constants=[Const("c_a", model.coef("a"), "GM(0,N) constant a"),
                   Const("c_X1", model.coef("X1"), "error at the first sample of the fit, um")]
        + [Const(f"c_b_{i}", model.coef(f"b_{i}"), f"GM(0,N) coefficient of {s.name}")
           for i, s in enumerate(temps, start=1)],
        regions=[_accumulate(model),
                 Region("GM(0,N): accumulated estimate and its first difference",
                        (Assign("X", level),
                         If(((Unary("NOT", Ref("Init")), (Assign("Xprev", BinOp("-", Ref("X"), const("X1"))),
                                                          Assign("Init", BoolConst(True)))),)),
                         Assign(model.target.name, BinOp("-", Ref("X"), Ref("Xprev"))),
                         Assign("Xprev", Ref("X"))))])


def lower_gm1n(model: Model) -> Block:
    """The GM(1,N) block: running sums of the temperatures and the grey difference equation run forward,
    output the first difference of its level (X1 at the first call)."""
    temps = model.signals("temperature")
    forced = sum_of([BinOp("*", const(f"b_{i}"), Ref(f"S_{i}")) for i in range(1, len(temps) + 1)])
    step = If(((Unary("NOT", Ref("Init")), (Assign("X", const("X1")), Assign("Init", BoolConst(True)))),),
              orelse=(Assign("X", BinOp("+", BinOp("*", const("Keep"), Ref("Xprev")), BinOp("*", const("In"), Ref("F")))),))
    return _grey_block(
        model, "Thermal compensation: grey model GM(1,N) (paper 003)",
        statics=[INIT, Var("Xprev", "REAL", "accumulated error estimate of the previous call")],
        temps_=[Var("F", "REAL", "sum of b_i*S_i"), Var("X", "REAL", "accumulated error estimate")],
        constants=[Const("c_X1", model.coef("X1"), "error at the first sample of the fit, um"),
                   Const("c_Keep", model.coef("Keep"), "(1 - a/2)/(1 + a/2), grey difference equation"),
                   Const("c_In", model.coef("In"), "1/(1 + a/2), grey difference equation")]
        + [Const(f"c_b_{i}", model.coef(f"b_{i}"), f"GM(1,N) coefficient of {s.name}") for i, s in enumerate(temps, start=1)],
        regions=[_accumulate(model),
                 Region("GM(1,N) grey difference equation: x1(k) + a*(X1(k) + X1(k-1))/2 = sum b_i*S_i(k)",
                        (Assign("F", forced), step,
                         Assign(model.target.name, BinOp("-", Ref("X"), Ref("Xprev"))),
                         Assign("Xprev", Ref("X"))))])


LOWERINGS = {"gm0n": lower_gm0n, "gm1n": lower_gm1n}  # model kind -> its lowering, collected by generator/lower.py
