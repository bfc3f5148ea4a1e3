"""Grey-model blocks of paper 003: GM(0,N) and GM(1,N) on accumulated temperatures."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, Block, BoolConst, Const, If, Ref, Region, Unary, Var
from thermoplc.models.model import Model
from thermoplc.generator.lower_shared import INIT, const, error_output, header, inputs_of, sum_of


def _grey_block(model: Model, title: str, statics, temps_, constants, regions) -> Block:
    temps = model.signals("temperature")
    return Block(
        name=model.block_name, title=title, header=header(model),
        inputs=inputs_of(temps),
        outputs=(error_output(model),),
        statics=tuple(statics), temps=tuple(temps_), constants=tuple(constants), regions=tuple(regions))


def _rises(model: Model) -> bool:
    """Whether the model works on the rises since the first call (a campaign's choice) or the readings."""
    return bool(model.settings.get("rises"))


def _first(model: Model) -> tuple[list[Var], tuple]:
    """The statics holding each temperature at the first call, and the statements that keep them."""
    temps = model.signals("temperature")
    return ([Var(f"T0_{i}", "REAL", f"{s.name} at the first call") for i, s in enumerate(temps, start=1)],
            tuple(Assign(f"T0_{i}", Ref(s.name)) for i, s in enumerate(temps, start=1)))


def _sequence(model: Model):
    """x_i(k) as the block reads it: the reading, or its rise since the first call."""
    return (lambda i, s: BinOp("-", Ref(s.name), Ref(f"T0_{i}"))) if _rises(model) else (lambda i, s: Ref(s.name))


def _weighted(model: Model, term, unit=const("b_0")) -> BinOp:
    """((b_1*term(1) + b_2*term(2)) + ...), in the references' order; with a unit sequence (b_0) its term
    `unit` first."""
    terms = [BinOp("*", const(f"b_{i}"), term(i, s)) for i, s in enumerate(model.signals("temperature"), 1)]
    return sum_of([unit, *terms] if _unit(model) else terms)


def _unit(model: Model) -> bool:
    """Whether the fit drove the model with a unit sequence (a campaign's offset), whose coefficient is b_0."""
    return "b_0" in model.coefficients


def _unit_constant(model: Model, kind: str) -> list[Const]:
    return [Const("c_b_0", model.coef("b_0"), f"{kind} coefficient of the unit sequence (offset), um")] \
        if _unit(model) else []


def lower_gm0n(model: Model) -> Block:
    """The GM(0,N) block: X1 at the first call, then the first difference of a + sum b_i*S_i, which is
    sum b_i*x_i (no running sums to grow)."""
    temps = model.signals("temperature")
    first, keep_first = _first(model) if _rises(model) else ([], ())
    return _grey_block(
        model, "Thermal compensation: grey model GM(0,N) (paper 003)",
        statics=[INIT, *first], temps_=[],
        constants=[Const("c_X1", model.coef("X1"), "error at the first sample of the fit, um")]
        + _unit_constant(model, "GM(0,N)")
        + [Const(f"c_b_{i}", model.coef(f"b_{i}"), f"GM(0,N) coefficient of {s.name}")
           for i, s in enumerate(temps, start=1)],
        regions=[Region("GM(0,N): first difference of a + sum b_i*S_i(k), i.e. sum b_i*x_i(k); X1 at the first call",
                        (If(((Unary("NOT", Ref("Init")), (*keep_first, Assign(model.target.name, const("X1")),
                                                          Assign("Init", BoolConst(True)))),),
                            orelse=(Assign(model.target.name, _weighted(model, _sequence(model))),)),))])


def lower_gm1n(model: Model) -> Block:
    """The GM(1,N) block: the grey difference equation differenced once, x1(k) = Keep*x1(k-1) +
    In*sum b_i*x_i(k), bounded however long it runs; X1 at the first call and the equation's own start at
    the second (the first temperatures kept for it)."""
    temps = model.signals("temperature")
    first, keep_first = _first(model)
    start = (*keep_first, Assign("X", const("X1")), Assign("Init", BoolConst(True)), Assign("Second", BoolConst(True)))
    at_start = _sequence(model) if _rises(model) else (lambda i, s: BinOp("+", Ref(f"T0_{i}"), Ref(s.name)))
    second = (Assign("F", _weighted(model, at_start, BinOp("+", const("b_0"), const("b_0")))),  # the unit's sum: 2
              Assign("X", BinOp("-", BinOp("+", BinOp("*", const("Keep"), Ref("Xprev")), BinOp("*", const("In"), Ref("F"))),
                                const("X1"))),
              Assign("Second", BoolConst(False)))
    later = (Assign("F", _weighted(model, _sequence(model))),
             Assign("X", BinOp("+", BinOp("*", const("Keep"), Ref("Xprev")), BinOp("*", const("In"), Ref("F")))))
    return _grey_block(
        model, "Thermal compensation: grey model GM(1,N) (paper 003)",
        statics=[INIT, Var("Second", "BOOL", "TRUE on the second call: the equation's start"),
                 Var("Xprev", "REAL", "error estimate of the previous call, um"), *first],
        temps_=[Var("F", "REAL", "sum of b_i*x_i"), Var("X", "REAL", "error estimate, um")],
        constants=[Const("c_X1", model.coef("X1"), "error at the first sample of the fit, um"),
                   Const("c_Keep", model.coef("Keep"), "(1 - a/2)/(1 + a/2), grey difference equation"),
                   Const("c_In", model.coef("In"), "1/(1 + a/2), grey difference equation")]
        + _unit_constant(model, "GM(1,N)")
        + [Const(f"c_b_{i}", model.coef(f"b_{i}"), f"GM(1,N) coefficient of {s.name}") for i, s in enumerate(temps, start=1)],
        regions=[Region("GM(1,N) grey difference equation x1(k) + a*(X1(k) + X1(k-1))/2 = sum b_i*S_i(k), differenced "
                        "once: x1(k) = Keep*x1(k-1) + In*sum b_i*x_i(k)",
                        (If(((Unary("NOT", Ref("Init")), start), (Ref("Second"), second)), orelse=later),
                         Assign(model.target.name, Ref("X")),
                         Assign("Xprev", Ref("X"))))])


LOWERINGS = {"gm0n": lower_gm0n, "gm1n": lower_gm1n}  # model kind -> its lowering, collected by generator/lower.py
