"""The fault hold's statements: while any input's fault bit is set, each output's model value stays within
c_FaultMove of its value the call before the fault began, that anchor fading to 0 by c_FaultFade per call. Knows the IR, not the models: the caller names the
fault bits and the temporaries holding the model values; models/fault_hold.py computes the same operations in
the same order.
"""
from __future__ import annotations

from functools import reduce

from thermoplc.generator.ir import Assign, BinOp, BoolConst, Call, If, Ref, Region, Unary, Var

HOLDING, ANY = "FaultHolding", "FaultAny"
COMMENTS = {"c_FaultMove": "while a fault bit is set each output stays this near its value before the fault "
                          "(--fault-move-um)",
            "c_FaultFade": "per call, that value's factor towards no compensation while the fault lasts "
                           "(--fault-fade-s)",
            "c_FaultFloor": "a faded value below this is 0 (before it becomes subnormal), um"}


def _names(k: int) -> tuple[str, str]:
    return f"FaultAnchor_{k}", f"FaultLast_{k}"


def hold_region(fault_bits: list[str], model_values: list[str]) -> Region:
    """Statements that keep each of `model_values` near its last value while one of `fault_bits` is TRUE."""
    count = len(model_values)
    anchors = [Assign(_names(k)[0], Ref(_names(k)[1])) for k in range(1, count + 1)]
    fades = [stmt for k in range(1, count + 1) for stmt in (
        Assign(_names(k)[0], BinOp("*", Ref(_names(k)[0]), Ref("c_FaultFade"))),
        If(((BinOp("<", Call("ABS", (Ref(_names(k)[0]),)), Ref("c_FaultFloor")), (Assign(_names(k)[0], Ref("c_Zero")),)),)))]
    held = []
    for k, value in enumerate(model_values, start=1):
        anchor = Ref(_names(k)[0])
        high, low = BinOp("+", anchor, Ref("c_FaultMove")), BinOp("-", anchor, Ref("c_FaultMove"))
        held.append(If(((BinOp(">", Ref(value), high), (Assign(value, high),)),
                        (BinOp("<", Ref(value), low), (Assign(value, low),)))))
    last = [If(((BinOp("<=", Call("ABS", (Ref(value),)), Ref("c_RealMax")), (Assign(_names(k)[1], Ref(value)),)),))
            for k, value in enumerate(model_values, start=1)]
    return Region("Fault hold: while a fault bit is set, each output stays near its value before, fading", (
        Assign(ANY, reduce(lambda a, b: BinOp("OR", a, b), [Ref(bit) for bit in fault_bits])),
        If(((Ref(ANY), (If(((Unary("NOT", Ref(HOLDING)), (*anchors, Assign(HOLDING, BoolConst(True)))),),
                           orelse=tuple(fades)),
                        *held)),), orelse=(Assign(HOLDING, BoolConst(False)),)),
        *last,
    ))


def declarations(count: int) -> dict:
    """The statics and temporaries the hold adds for `count` outputs."""
    return {"statics": (Var(HOLDING, "BOOL", "a fault bit was set in the last call: the anchors hold"),
                        *(v for k in range(1, count + 1) for v in (
                            Var(_names(k)[0], "REAL", "the model value this output is held near while faulty"),
                            Var(_names(k)[1], "REAL", "the model value of the last call (finite)")))),
            "temps": (Var(ANY, "BOOL", "some input's fault bit is set"),)}
