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
    temps = model.signals("temperature")
    level = sum_of([const("a")] + [BinOp("*", const(f"b_{i}"), Ref(f"S_{i}")) for i in range(1, len(temps) + 1)])
    return _grey_block(
        model, "Thermal error compensation: grey model GM(0,N) (paper 003)",
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
    temps = model.signals("temperature")
    forced = sum_of([BinOp("*", const(f"g_{i}"), Ref(f"S_{i}")) for i in range(1, len(temps) + 1)])
    damping = If(((Unary("NOT", Ref("Init")), (Assign("Damp", const("One")), Assign("Init", BoolConst(True)))),),
                 orelse=(Assign("Damp", BinOp("*", Ref("Damp"), const("Decay"))),
                         If(((BinOp("<", Ref("Damp"), const("Tiny")), (Assign("Damp", const("Zero")),)),))))
    return _grey_block(
        model, "Thermal error compensation: grey model GM(1,N) (paper 003)",
        statics=[INIT,
                 Var("Damp", "REAL", "exp(-a*(k-1)) by recurrence"),
                 Var("Xprev", "REAL", "accumulated error estimate of the previous call")],
        temps_=[Var("F", "REAL", "sum of (b_i/a)*S_i"), Var("X", "REAL", "accumulated error estimate")],
        constants=[Const("c_X1", model.coef("X1"), "error at the first sample of the fit, um"),
                   Const("c_Decay", model.coef("Decay"), "exp(-a)"),
                   Const("c_Tiny", model.coef("Tiny"), "flush exp(-a*k) to 0 below this (no subnormals)"),
                   Const("c_One", 1.0, "exp(0)"), Const("c_Zero", 0.0, "flushed damping")]
        + [Const(f"c_g_{i}", model.coef(f"g_{i}"), f"b/a for {s.name}") for i, s in enumerate(temps, start=1)],
        regions=[_accumulate(model),
                 Region("GM(1,N) time response: damping exp(-a*(k-1)) by recurrence", (damping,)),
                 Region("GM(1,N): accumulated estimate and its first difference",
                        (Assign("F", forced),
                         Assign("X", BinOp("+", BinOp("*", BinOp("-", const("X1"), Ref("F")), Ref("Damp")), Ref("F"))),
                         Assign(model.target.name, BinOp("-", Ref("X"), Ref("Xprev"))),
                         Assign("Xprev", Ref("X"))))])
