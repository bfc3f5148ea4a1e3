"""The probe fusion's statements: the model's target value moved by an offset (and rate) state that each
accepted probing updates. Knows the IR, not the models: the caller gives the constants' names and which
state the fusion keeps; models/probing.py computes the same operations in the same order.
"""
from __future__ import annotations

from dataclasses import dataclass

from thermoplc.generator.ir import Assign, BinOp, BoolConst, Call, If, IntConst, Ref, Region, Unary, Var
from thermoplc.contract.outputs import (PROBE_INPUT_START, PROBE_NEW_INPUT, PROBE_REFUSALS_OUTPUT,
                                        PROBE_REFUSED_OUTPUT, PROBE_SUSPECT_OUTPUT, PROBE_USED_OUTPUT,
                                        PROBE_VALUE_INPUT)

OFFSET, RATE, SEEN, INNOVATION, MISSED, ANCHORED = ("ProbeOffset", "ProbeRate", "ProbeSeen", "ProbeInnov",
                                                    "ProbeMissed", "ProbeAnchored")
LAST, SAME, STUCK_REF, HELD, SINCE, ANY = ("ProbeLast", "ProbeSame", "ProbeStuckRef", "ProbeHeld", "ProbeSince",
                                           "ProbeAny")
COMMENTS = {
    "c_ProbeGain": "share of a probing's innovation taken into the offset (steady-state Kalman gain)",
    "c_ProbeRateGain": "share of a probing's innovation taken into the drift rate, um per call per um",
    "c_ProbeDecay": "the offset's factor per call between probings (1: held)",
    "c_ProbeGate": "a probing further than this from the prediction is refused, um",
    "c_ProbeLimit": "a probing beyond +-this (or NaN/Inf) is refused, um",
    "c_ProbeOffsetMax": "offset clamp, um", "c_ProbeOffsetMin": "offset clamp, negative side, um",
    "c_ProbeRateMax": "drift rate clamp, um per call", "c_ProbeRateMin": "drift rate clamp, negative side",
    "c_ProbeCountMax": "the refusal counter stops here", "c_ProbeOne": "one refusal",
    "c_ProbeRejoin": "after this many probings in a row beyond the gate the next is taken (the drift moved)",
    "c_ProbeStuckCount": "a probing equal to the last this many, the prediction moved since: frozen",
    "c_ProbeStuckMove": "the prediction's move that makes equal probings frozen: a quarter of the gate, um",
    "c_ProbeHeldMax": "calls ProbeNew may stay TRUE; longer is a stuck bit (ProbeSuspect)",
    "c_ProbeMinCalls": "a probing sooner than this many calls after the last floods (half the fitted schedule)",
}


@dataclass(frozen=True)
class Fusion:
    """The fused output, the constants (name -> binary32 value or INT) and which state the block keeps: a drift
    rate beside the offset, a decay of the offset between probings."""
    target: str
    constants: dict
    rate: bool
    decay: bool
    flood: bool  # the schedule is known: a probing too soon after the last is suspect


def _count(name: str) -> If:
    """`name` one up, stopping at the INT counter's end."""
    return If(((BinOp("<", Ref(name), Ref("c_ProbeCountMax")),
                (Assign(name, BinOp("+", Ref(name), Ref("c_ProbeOne"))),)),))


def _clamp(name: str, low: str, high: str) -> If:
    return If(((BinOp(">", Ref(name), Ref(high)), (Assign(name, Ref(high)),)),
               (BinOp("<", Ref(name), Ref(low)), (Assign(name, Ref(low)),))))


def fusion_region(fusion: Fusion, model_value: str) -> Region:
    """Statements that fuse the probing into `model_value` (the temporary holding the model's target)."""
    stmts: list = []
    if fusion.rate:
        stmts.append(Assign(OFFSET, BinOp("+", Ref(OFFSET), Ref(RATE))))
    if fusion.decay:
        stmts.append(Assign(OFFSET, BinOp("*", Ref(OFFSET), Ref("c_ProbeDecay"))))
    update = [Assign(OFFSET, BinOp("+", Ref(OFFSET), BinOp("*", Ref("c_ProbeGain"), Ref(INNOVATION))))]
    if fusion.rate:
        update.append(Assign(RATE, BinOp("+", Ref(RATE), BinOp("*", Ref("c_ProbeRateGain"), Ref(INNOVATION)))))
    update += [Assign(PROBE_USED_OUTPUT, BoolConst(True)), Assign(MISSED, IntConst(0)),
               Assign(ANCHORED, BoolConst(True))]
    missed = (Assign(MISSED, BinOp("+", Ref(MISSED), Ref("c_ProbeOne"))),)
    innovation = Assign(INNOVATION, BinOp("-", Ref(PROBE_VALUE_INPUT), BinOp("+", Ref(model_value), Ref(OFFSET))))
    frozen = BinOp("AND", BinOp(">=", Ref(SAME), Ref("c_ProbeStuckCount")),
                   BinOp(">", Call("ABS", (BinOp("-", Ref(model_value), Ref(STUCK_REF)),)), Ref("c_ProbeStuckMove")))
    suspect = BinOp("OR", BinOp("AND", Ref(ANY), BinOp("<", Ref(SINCE), Ref("c_ProbeMinCalls"))), frozen) \
        if fusion.flood else frozen
    plausibility = (
        If(((BinOp("=", Ref(PROBE_VALUE_INPUT), Ref(LAST)), (_count(SAME),)),),
           orelse=(Assign(SAME, IntConst(0)), Assign(STUCK_REF, Ref(model_value)))),
        Assign(LAST, Ref(PROBE_VALUE_INPUT)),
        Assign(PROBE_SUSPECT_OUTPUT, suspect),
        *((Assign(ANY, BoolConst(True)), Assign(SINCE, IntConst(0))) if fusion.flood else ()),
    )
    judged = If(((BinOp("AND", Unary("NOT", Ref(PROBE_SUSPECT_OUTPUT)),
                        BinOp("<=", Call("ABS", (Ref(PROBE_VALUE_INPUT),)), Ref("c_ProbeLimit"))), (
        innovation,
        If(((BinOp("OR", BinOp("OR", BinOp("<=", Call("ABS", (Ref(INNOVATION),)), Ref("c_ProbeGate")),
                                  Unary("NOT", Ref(ANCHORED))),
                      BinOp(">=", Ref(MISSED), Ref("c_ProbeRejoin"))), tuple(update)),), orelse=missed),
    )),))
    refused = If(((Unary("NOT", Ref(PROBE_USED_OUTPUT)), (
        Assign(PROBE_REFUSED_OUTPUT, BoolConst(True)),
        If(((BinOp("<", Ref(PROBE_REFUSALS_OUTPUT), Ref("c_ProbeCountMax")),
             (Assign(PROBE_REFUSALS_OUTPUT, BinOp("+", Ref(PROBE_REFUSALS_OUTPUT), Ref("c_ProbeOne"))),)),)),
    )),))
    new = BinOp("AND", Ref(PROBE_NEW_INPUT), Unary("NOT", Ref(SEEN)))
    stmts += [
        If(((Ref(PROBE_NEW_INPUT), (_count(HELD),)),), orelse=(Assign(HELD, IntConst(0)),)),
        *((_count(SINCE),) if fusion.flood else ()),
        Assign(PROBE_USED_OUTPUT, BoolConst(False)),
        Assign(PROBE_REFUSED_OUTPUT, BoolConst(False)),
        If(((new, (*plausibility, judged, refused)),)),
        Assign(SEEN, Ref(PROBE_NEW_INPUT)),
        If(((BinOp(">", Ref(HELD), Ref("c_ProbeHeldMax")), (Assign(PROBE_SUSPECT_OUTPUT, BoolConst(True)),)),)),
        _clamp(OFFSET, "c_ProbeOffsetMin", "c_ProbeOffsetMax"),
    ]
    if fusion.rate:
        stmts.append(_clamp(RATE, "c_ProbeRateMin", "c_ProbeRateMax"))
    stmts.append(Assign(model_value, BinOp("+", Ref(model_value), Ref(OFFSET))))
    return Region("Probe fusion: an accepted probing moves the offset by the gain times its innovation", tuple(stmts))


def declarations(fusion: Fusion) -> dict:
    """The inputs, outputs, statics and temporaries the fusion adds."""
    return {
        "inputs": (Var(PROBE_VALUE_INPUT, "REAL", "the latest probing of the target, um (from the NC's probing cycle)"),
                   Var(PROBE_NEW_INPUT, "BOOL", "rising edge: ProbeValue is a new probing at this call",
                       initial=PROBE_INPUT_START[PROBE_NEW_INPUT])),
        "outputs": (Var(PROBE_USED_OUTPUT, "BOOL", "a probing was taken into the offset in this call"),
                    Var(PROBE_REFUSED_OUTPUT, "BOOL", "a probing was refused in this call (NaN, beyond the limit or "
                                                      "the gate): the state is unchanged"),
                    Var(PROBE_REFUSALS_OUTPUT, "INT", "probings refused since the start or the last Reset"),
                    Var(PROBE_SUSPECT_OUTPUT, "BOOL", "the probe looks faulty (frozen value, ProbeNew stuck TRUE or "
                                                      "probings faster than the schedule): probings are refused until "
                                                      "a plausible one; wire it to a message")),
        "statics": (Var(OFFSET, "REAL", "offset the probings have taught, um"),
                    *((Var(RATE, "REAL", "drift rate the probings have taught, um per call"),) if fusion.rate else ()),
                    Var(SEEN, "BOOL", "ProbeNew in the last call (its rising edge is a new probing)"),
                    Var(MISSED, "INT", "probings in a row refused by the gate"),
                    Var(ANCHORED, "BOOL", "a probing was taken since the start: the gate judges the next ones"),
                    Var(LAST, "REAL", "the last probing's value, um"),
                    Var(SAME, "INT", "probings in a row equal to the one before"),
                    Var(STUCK_REF, "REAL", "the model's value at the first of those equal probings, um"),
                    Var(HELD, "INT", "calls ProbeNew has been TRUE in a row"),
                    *((Var(SINCE, "INT", "calls since the last probing"),
                       Var(ANY, "BOOL", "a probing came since the start")) if fusion.flood else ())),
        "temps": (Var(INNOVATION, "REAL", "probing minus prediction, um"),),
    }
