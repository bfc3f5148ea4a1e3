"""nonlinear_speed_heat in the block: the speed heat S is the n^p table interpolated at n, the segment
chosen by comparisons only (models/kinds/lumped_model.py computes the same)."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, If, Index, IntConst, Ref, Region, Var
from thermoplc.generator.lumped_effects.lowering import EffectLowering, Lumped, Speed
from thermoplc.models.kinds import lumped_model

TABLES = (("node", "speed table nodes, rpm"), ("heat", "speed heat n^p at the nodes"),
          ("slope", "speed heat slope per rpm"))


def speed(block: Lumped) -> Speed | None:
    model, n = block.model, block.speed
    count = lumped_model.segments(model)
    if not count:
        return None
    chain = tuple((BinOp(">=", n, Index("tab_Node", IntConst(m))), (Assign("Ix", IntConst(m)),))
                  for m in range(count - 1, 0, -1))
    interpolate = Assign("S", BinOp("+", Index("tab_Heat", Ref("Ix")),
                                    BinOp("*", BinOp("-", n, Index("tab_Node", Ref("Ix"))), Index("tab_Slope", Ref("Ix")))))
    tables = tuple(Var(f"tab_{stem.capitalize()}", "REAL", f"{comment} (table, read only)", length=count,
                       initial=tuple(model.coef(f"{stem}_{m}") for m in range(1, count + 1)))
                   for stem, comment in TABLES)
    body = (If(chain, orelse=(Assign("Ix", IntConst(0)),)),) if count > 1 else (Assign("Ix", IntConst(0)),)
    return Speed(Region("Speed heat input n^p from the table (nonlinear_speed_heat)", (*body, interpolate)),
                 (Var("Ix", "INT", "speed table segment"), *tables))


LOWERING = EffectLowering("nonlinear_speed_heat", table_stems=tuple(stem for stem, _ in TABLES), speed=speed)
