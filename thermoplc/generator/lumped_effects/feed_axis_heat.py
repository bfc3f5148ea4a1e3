"""feed_axis_heat in the block: LF lags the feed rate from 0 (pole AF/BF) and phi weighs it."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, Const, Ref, Var
from thermoplc.generator.lower_shared import const
from thermoplc.generator.lumped_effects.lowering import EffectLowering, Lumped, State, lag


def state(block: Lumped) -> State:
    return State(init=(Assign("LF", const("Zero")),), statics=(Var("LF", "REAL", "feed-axis heat, lagged"),),
                 constants=(Const("c_Zero", 0.0, "feed heat at the first call"),))


def step(block: Lumped) -> tuple:
    return (lag("LF", "AF", "BF", Ref(block.model.signals("feed")[0].name)),)


def term(block: Lumped) -> tuple:
    return (BinOp("*", const("phi"), Ref("LF")),)


COMMENTS = (
    ("AF", "feed heat decay per call"),
    ("BF", "1 - AF"),
    ("phi", "um per mm/min of lagged feed"),
)

LOWERING = EffectLowering("feed_axis_heat", comments=COMMENTS, shared_state=state, shared=step, terms=term)
