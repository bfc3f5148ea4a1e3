"""gear_ratio_switch in the block: above c_Gear_rpm each sensor's heat input gains G2_i * n."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, If, Ref
from thermoplc.generator.lower_shared import const
from thermoplc.generator.lumped_effects.lowering import EffectLowering, Lumped


def heat(block: Lumped, i: int) -> tuple:
    return (If(((BinOp(">", block.speed, const("Gear_rpm")),
                 (Assign("Q", BinOp("+", Ref("Q"), BinOp("*", const(f"G2_{i}"), block.speed))),)),)),)


COMMENTS = (
    ("G2", "extra rise per rpm above the gear threshold, K"),
    ("Gear", "gear threshold, rpm"),
)

LOWERING = EffectLowering("gear_ratio_switch", comments=COMMENTS, heat=heat)
