"""The Bayesian-network block of paper 004: interval search and a table of expected errors."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, Block, Const, If, Index, IntConst, Ref, Region, Var
from thermoplc.models.bayes import edges_of
from thermoplc.models.modelfile import Model
from thermoplc.generator.lower_shared import (
    INIT, const, error_output, first_call, header, inputs_of, reference_vars, references,
)


def lower_bayes(model: Model) -> Block:
    temps = model.signals("temperature")
    counts = model.settings["intervals"]
    regions, statics, constants = [], [], []
    for i, s in enumerate(temps, start=1):
        edges = tuple(edges_of(model, i))
        if edges:
            statics.append(Var(f"tab_Edge_{i}", "REAL", f"interval edges of the rise of {s.name}, K (table, read only)",
                               length=len(edges), initial=edges))
            chain = tuple((BinOp("<", Ref("Rise"), Index(f"tab_Edge_{i}", IntConst(m))), (Assign(f"J_{i}", IntConst(m)),))
                          for m in range(len(edges)))
            choose = If(chain, orelse=(Assign(f"J_{i}", IntConst(len(edges))),))
        else:
            choose = Assign(f"J_{i}", IntConst(0))
        regions.append(Region(f"Interval of the rise of {s.name} ({counts[i - 1]} intervals)", (
            Assign("Rise", BinOp("-", Ref(s.name), Ref(f"T0_{i}"))), choose)))
        if i < len(temps):  # the last sensor's count does not enter the configuration index
            constants.append(Const(f"c_K_{i}", counts[i - 1], f"intervals of {s.name}", type="INT"))
    config = Ref(f"J_{len(temps)}")
    for i in range(len(temps) - 1, 0, -1):
        config = BinOp("+", Ref(f"J_{i}"), BinOp("*", const(f"K_{i}"), config))
    table = tuple(model.coef(f"pred_{c}") for c in range(model.settings["configurations"]))
    return Block(
        name=model.block_name,
        title="Thermal error compensation: Bayesian network, most probable error interval (paper 004)",
        header=header(model),
        inputs=inputs_of(temps),
        outputs=(error_output(model),),
        statics=(INIT, *reference_vars(temps), *statics,
                 Var("tab_Pred", "REAL", "midpoint of the most probable error interval per configuration, um "
                     "(table, read only)", length=len(table), initial=table)),
        temps=(Var("Rise", "REAL", "temperature rise since the first call"),
               *(Var(f"J_{i}", "INT", f"interval of {s.name}") for i, s in enumerate(temps, start=1)),
               Var("Config", "INT", "configuration of all intervals")),
        constants=tuple(constants),
        regions=(first_call("First call: latch reference temperatures", references(temps)),
                 *regions,
                 Region("Look up the prediction of the configuration, eq. 7",
                        (Assign("Config", config), Assign(model.target.name, Index("tab_Pred", Ref("Config")))))),
    )
