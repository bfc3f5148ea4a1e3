"""stop_convection in the block: at or below c_Stop_rpm each sensor lags with its standstill pole."""
from __future__ import annotations

from thermoplc.generator.ir import BinOp, If
from thermoplc.generator.lower_shared import const
from thermoplc.generator.lumped_effects.lowering import EffectLowering, Lumped, lag


def step(block: Lumped, i: int, drive, running):
    return If(((BinOp("<=", block.speed, const("Stop_rpm")), (lag(f"Tsim_{i}", f"As_{i}", f"Bs_{i}", drive),)),),
              orelse=(running,))


COMMENTS = (
    ("As", "decay per call at standstill (stop_convection)"),
    ("Bs", "1 - As"),
    ("Stop", "standstill at or below, rpm"),
)

LOWERING = EffectLowering("stop_convection", comments=COMMENTS, step=step)
