"""The Bayesian-network block of paper 004: interval search and a table of expected errors."""
from __future__ import annotations

from thermoplc.base.binary32 import round_f32
from thermoplc.generator.ir import Assign, BinOp, Block, Const, If, Index, IntConst, Ref, Region, Var
from thermoplc.models.kinds.bayes import counted, edges_of
from thermoplc.models.model import Model
from thermoplc.generator.lower_shared import (
    INIT, const, error_output, first_call, header, inputs_of, reference_vars, references, weighted_rises,
)


def lower_bayes(model: Model) -> Block:
    temps = model.signals("temperature")
    counts = model.settings["intervals"]
    timed = bool(model.settings.get("time_parent"))
    clock, regions, statics, constants = [], [], [], []
    # each parent: its label, the value its interval is found for, the unit of its edges
    ridge_parent = model.settings.get("parents") == "ridge"
    lookup = Index("tab_Pred", Ref("Config"))
    if ridge_parent:  # the prediction, its interval a parent, plus the residual's entry
        parents = [("the ridge prediction", Ref("Ridge"), "um")]
        regions.append(Region("Ridge prediction from every temperature's rise (the parent of the network)", (
            Assign("Ridge", weighted_rises("w_0", "w", temps)),)))
        constants += [Const("c_w_0", model.coef("w_0"), "intercept of the ridge prediction, um")]
        constants += [Const(f"c_w_{i}", model.coef(f"w_{i}"), f"um per K of {s.name} in the ridge prediction")
                      for i, s in enumerate(temps, start=1)]
        lookup = BinOp("+", Ref("Ridge"), lookup)
        ridge_vars = (Var("Ridge", "REAL", "the ridge prediction, um"),)
        entries = "midpoint of the most probable interval of what the ridge prediction leaves, per configuration, um"
    else:
        parents = [(f"the rise of {s.name}", BinOp("-", Ref(s.name), Ref(f"T0_{i}")), "K")
                   for i, s in enumerate(temps, start=1)]
        ridge_vars = ()
        entries = "midpoint of the most probable error interval per configuration, um"
    if timed:
        parents.append(("the time since the first call", Ref("Elapsed"), "s"))
        clock.append(Region("Time since the first call (a parent of the network), before Init is set", (
            If(((Ref("Init"), (Assign("Elapsed", BinOp("+", Ref("Elapsed"), Ref("c_Dt"))),)),)),)))
        statics.append(Var("Elapsed", "REAL", "seconds since the first call"))
        constants.append(Const("c_Dt", round_f32(model.sample_period_s), "seconds per call"))
    for i, (label, value, unit) in enumerate(parents, start=1):
        edges = tuple(edges_of(model, i))
        if edges:
            statics.append(Var(f"tab_Edge_{i}", "REAL", f"interval edges of {label}, {unit} (table, read only)",
                               length=len(edges), initial=edges))
            chain = tuple((BinOp("<", Ref("Rise"), Index(f"tab_Edge_{i}", IntConst(m))), (Assign(f"J_{i}", IntConst(m)),))
                          for m in range(len(edges)))
            choose = If(chain, orelse=(Assign(f"J_{i}", IntConst(len(edges))),))
        else:
            choose = Assign(f"J_{i}", IntConst(0))
        regions.append(Region(f"Interval of {label} ({counted(counts[i - 1], 'interval')})", (Assign("Rise", value), choose)))
        if i < len(parents):  # the last parent's count does not enter the configuration index
            constants.append(Const(f"c_K_{i}", counts[i - 1], f"intervals of {label}", type="INT"))
    config = Ref(f"J_{len(parents)}")
    for i in range(len(parents) - 1, 0, -1):
        config = BinOp("+", Ref(f"J_{i}"), BinOp("*", const(f"K_{i}"), config))
    table = tuple(model.coef(f"pred_{c}") for c in range(model.settings["configurations"]))
    return Block(
        name=model.block_name,
        title="Thermal compensation: Bayesian network (paper 004)",
        header=header(model),
        inputs=inputs_of(temps),
        outputs=(error_output(model),),
        statics=(INIT, *reference_vars(temps), *statics,
                 Var("tab_Pred", "REAL", f"{entries} (table, read only)", length=len(table), initial=table)),
        temps=(*ridge_vars, Var("Rise", "REAL", "value of the parent whose interval is sought"),
               *(Var(f"J_{i}", "INT", f"interval of {label}") for i, (label, _, _) in enumerate(parents, start=1)),
               Var("Config", "INT", "configuration of all intervals")),
        constants=tuple(constants),
        regions=(*clock,
                 first_call("First call: latch reference temperatures", references(temps)),
                 *regions,
                 Region("Look up the prediction of the configuration, eq. 7",
                        (Assign("Config", config), Assign(model.target.name, lookup)))),
    )


LOWERINGS = {"bayes": lower_bayes}  # model kind -> its lowering, collected by generator/lower.py
