"""Regression blocks: mlr (eq. 10), the piecewise ambient library (paper 001), distributed lags."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, Block, Const, For, If, Index, IntConst, Ref, Region, Var
from thermoplc.models.model import Model
from thermoplc.models.kinds.piecewise import node_count
from thermoplc.generator.lower_shared import (
    INIT, const, error_output, first_call, header, inputs_of, reference_vars, references, regression,
    regression_constants, sum_of,
)


def lower_mlr(model: Model) -> Block:
    """The mlr block: the temperatures latched at the first call, then eq. 10 on their rises at every call."""
    temps = model.signals("temperature")
    return Block(
        name=model.block_name,
        title="Thermal compensation: multiple linear regression",
        header=header(model),
        inputs=inputs_of(temps),
        outputs=(error_output(model),),
        statics=(INIT, *reference_vars(temps)),
        temps=(),
        constants=tuple(regression_constants(model)),
        regions=(
            first_call("First call: latch reference temperatures", references(temps)),
            regression(model, lambda i, s: Ref(s.name)),
        ),
    )

def lower_piecewise(model: Model) -> Block:
    """The piecewise block: the first call latches the ambient and picks the two nodes around it and their
    weights; every call blends those two nodes' regressions (eq. 1)."""
    temps = model.signals("temperature")
    ambient = model.signals("ambient")[0].name
    count = node_count(model)
    nodes = lambda index: Index("tab_Node", index)

    def table(name: str, stem: str, comment: str) -> Var:
        values = tuple(model.coef(f"{stem}_{m}") for m in range(1, count + 1))
        return Var(name, "REAL", f"{comment} (table, read only)", length=count, initial=values)

    chain = [(BinOp("<=", Ref("Amb0"), nodes(IntConst(0))), (Assign("Ia", IntConst(0)), Assign("Ib", IntConst(0))))]
    chain += [(BinOp("<=", Ref("Amb0"), nodes(IntConst(j))), (Assign("Ia", IntConst(j - 1)), Assign("Ib", IntConst(j))))
              for j in range(1, count)]
    last = (Assign("Ia", IntConst(count - 1)), Assign("Ib", IntConst(count - 1)))
    span = BinOp("-", nodes(Ref("Ib")), nodes(Ref("Ia")))
    weights = If(((BinOp("=", Ref("Ia"), Ref("Ib")), (Assign("Wa", const("One")), Assign("Wb", const("Zero")))),),
                 orelse=(Assign("Wa", BinOp("/", BinOp("-", nodes(Ref("Ib")), Ref("Amb0")), span)),
                         Assign("Wb", BinOp("/", BinOp("-", Ref("Amb0"), nodes(Ref("Ia"))), span))))
    latch = (*references(temps), Assign("Amb0", Ref(ambient)), If(tuple(chain), orelse=last), weights)

    def node_model(which: str) -> Assign:
        index = Ref(f"I{which}")
        terms = [Index("tab_Beta0", index)] + [
            BinOp("*", Index(f"tab_Beta_{i}", index), BinOp("-", Ref(s.name), Ref(f"T0_{i}")))
            for i, s in enumerate(temps, start=1)]
        return Assign(f"Y{which}", sum_of(terms))

    tables = [table("tab_Node", "node", "node ambient temperatures, degC"),
              table("tab_Beta0", "beta0", "intercept per node, um")]
    tables += [Var(f"tab_Beta_{i}", "REAL", f"um per K of {s.name} per node (table, read only)", length=count,
                   initial=tuple(model.coef(f"beta_{i}_{m}") for m in range(1, count + 1)))
               for i, s in enumerate(temps, start=1)]
    return Block(
        name=model.block_name,
        title="Thermal compensation: ambient model library (paper 001)",
        header=header(model),
        inputs=inputs_of(model.inputs),
        outputs=(error_output(model),),
        statics=(INIT,
                 Var("Amb0", "REAL", f"{ambient} at the first call"),
                 Var("Ia", "INT", "lower node"), Var("Ib", "INT", "upper node"),
                 Var("Wa", "REAL", "weight of the lower node, eq. 1"), Var("Wb", "REAL", "weight of the upper node"),
                 *reference_vars(temps),
                 *tables),
        temps=(Var("Ya", "REAL", "prediction of the lower node's model"),
               Var("Yb", "REAL", "prediction of the upper node's model")),
        constants=(Const("c_One", 1.0, "weight of a single node"), Const("c_Zero", 0.0, "weight of no node")),
        regions=(
            first_call("First call: latch temperatures, ambient, the two nearest nodes and their weights (eq. 1)",
                        latch),
            Region("Regression model of each chosen node", (node_model("a"), node_model("b"))),
            Region("Weighted sum of the two node models, eq. 1",
                   (Assign(model.target.name, BinOp("+", BinOp("*", Ref("Wa"), Ref("Ya")),
                                                    BinOp("*", Ref("Wb"), Ref("Yb")))),)),
        ),
    )

def lower_dlag(model: Model) -> Block:
    """The dlag block: a ring buffer of lags * lag_step_samples + 1 samples per temperature, filled with the
    first reading, and the regression on the current and lagged rises."""
    temps = model.signals("temperature")
    lags, step = model.settings["lags"], model.settings["lag_step_samples"]
    length = lags * step + 1
    fill = tuple(For("I", IntConst(0), const("Last"), (Assign(f"Buf_{i}", Ref(s.name), index=Ref("I")),))
                 for i, s in enumerate(temps, start=1))
    latch = (*references(temps), *fill, Assign("Pos", IntConst(0)))
    advance = (Assign("Pos", BinOp("+", Ref("Pos"), const("One"))),
               If(((BinOp(">", Ref("Pos"), const("Last")), (Assign("Pos", IntConst(0)),)),)),
               *(Assign(f"Buf_{i}", Ref(s.name), index=Ref("Pos")) for i, s in enumerate(temps, start=1)))
    terms: list = [Assign("Acc", const("beta0"))]
    for lag in range(lags + 1):
        terms += [Assign("Idx", BinOp("-", Ref("Pos"), const(f"Lag_{lag}"))),
                  If(((BinOp("<", Ref("Idx"), IntConst(0)), (Assign("Idx", BinOp("+", Ref("Idx"), const("Len"))),)),))]
        terms += [Assign("Acc", BinOp("+", Ref("Acc"), BinOp("*", const(f"beta_{i}_{lag}"),
                                                              BinOp("-", Index(f"Buf_{i}", Ref("Idx")), Ref(f"T0_{i}")))))
                  for i in range(1, len(temps) + 1)]
    constants = [Const("c_beta0", model.coef("beta0"), "intercept, um"),
                 Const("c_One", 1, "ring buffer step", type="INT"),
                 Const("c_Len", length, "ring buffer length, samples", type="INT"),
                 Const("c_Last", length - 1, "last ring buffer index", type="INT")]
    constants += [Const(f"c_Lag_{lag}", lag * step, f"lag {lag}: {lag * step} samples back", type="INT")
                  for lag in range(lags + 1)]
    constants += [Const(f"c_beta_{i}_{lag}", model.coef(f"beta_{i}_{lag}"), f"um per K of {s.name}, lag {lag}")
                  for lag in range(lags + 1) for i, s in enumerate(temps, start=1)]
    return Block(
        name=model.block_name,
        title="Thermal compensation: distributed-lag regression (paper 001)",
        header=header(model),
        inputs=inputs_of(temps),
        outputs=(error_output(model),),
        statics=(INIT, Var("Pos", "INT", "ring buffer position of now"), *reference_vars(temps),
                 *(Var(f"Buf_{i}", "REAL", f"last {length} samples of {s.name}", length=length)
                   for i, s in enumerate(temps, start=1))),
        temps=(Var("I", "INT", "loop index"), Var("Idx", "INT", "ring buffer index of a lag"),
               Var("Acc", "REAL", "sum of the terms so far")),
        constants=tuple(constants),
        regions=(first_call("First call: latch reference temperatures, fill the ring buffers", latch),
                 Region("Store this call's temperatures in the ring buffers", advance),
                 Region("Regression on current and lagged temperature rises", tuple(terms)
                        + (Assign(model.target.name, Ref("Acc")),))),
    )


LOWERINGS = {"mlr": lower_mlr, "dlag": lower_dlag, "piecewise": lower_piecewise}  # model kind -> its lowering, collected by generator/lower.py
