"""ambient_coupling in the block: LA lags the ambient (pole AAm/BAm) and alpha weighs its rise."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, Ref, Var
from thermoplc.generator.lower_shared import const
from thermoplc.generator.lumped_effects.lowering import EffectLowering, Lumped, State, lag


def state(block: Lumped) -> State:
    return State(init=(Assign("LA", block.ambient),),
                 statics=(Var("LA", "REAL", "structure following the ambient, degC"),))


def step(block: Lumped) -> tuple:
    return (lag("LA", "AAm", "BAm", block.ambient),)


def term(block: Lumped) -> tuple:
    return (BinOp("*", const("alpha"), BinOp("-", Ref("LA"), Ref("Te0"))),)


COMMENTS = (
    ("AAm", "ambient coupling decay per call"),
    ("BAm", "1 - AAm"),
    ("alpha", "um per K of the lagged ambient"),
)

LOWERING = EffectLowering("ambient_coupling", comments=COMMENTS, shared_state=state, shared=step, terms=term)
