"""The known start's statements: at the first call with a finite model value the target is moved to the
drift the runs started at, and that offset fades by a factor per call. Knows the IR, not the models: the
caller names the temporary holding the model's target; models/start.py computes the same operations in the
same order.
"""
from __future__ import annotations

from dataclasses import dataclass

from thermoplc.generator.ir import Assign, BinOp, BoolConst, Call, If, Ref, Region, Unary, Var

OFFSET, LATCHED = "StartOffset", "StartLatched"
CONSTANTS = {"c_StartDrift": "drift measured at the start of the training runs, um: the output at the first call",
             "c_StartDecay": "factor per call by which the model's start error fades (fitted on the training runs)",
             "c_StartFloor": "a start offset below this is gone (set to 0 before it becomes subnormal), um"}


@dataclass(frozen=True)
class KnownStart:
    """The output the start moves and its constants (name -> binary32 value)."""
    target: str
    constants: dict


def start_region(model_value: str) -> Region:
    """Statements that move `model_value` (the temporary holding the model's target) by the start offset."""
    latch = If(((BinOp("<=", Call("ABS", (Ref(model_value),)), Ref("c_RealMax")), (
        Assign(OFFSET, BinOp("-", Ref("c_StartDrift"), Ref(model_value))),
        Assign(LATCHED, BoolConst(True)))),))
    return Region("Known start: the output starts at the drift the runs started at; the model's start error fades", (
        If(((Unary("NOT", Ref(LATCHED)), (latch,)),), orelse=(Assign(OFFSET, BinOp("*", Ref(OFFSET), Ref("c_StartDecay"))),)),
        If(((BinOp("<", Call("ABS", (Ref(OFFSET),)), Ref("c_StartFloor")), (Assign(OFFSET, Ref("c_Zero")),)),)),
        Assign(model_value, BinOp("+", Ref(model_value), Ref(OFFSET))),
    ))


STATICS = (Var(OFFSET, "REAL", "start offset: the drift at the start minus the model's first value, fading, um"),
           Var(LATCHED, "BOOL", "the start offset was latched (first call with a finite model value)"))
