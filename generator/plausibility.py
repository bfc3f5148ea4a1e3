"""The cross-sensor check's statements: SensorsDisagree when a held temperature differs from what the other
temperatures say by more than its gate, until they agree again for c_SettleCalls calls. Knows the IR, not the models: the caller names, per checked input, the
variable holding its good value and the constants of its relation; models/plausibility.py computes the same
operations in the same order.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import reduce

from thermoplc.contract.outputs import DISAGREE_OUTPUT, READY_OUTPUT
from thermoplc.generator.ir import Assign, BinOp, BoolConst, Call, If, IntConst, Ref, Region, Unary, Var

RESIDUAL, FAR, CALM, QUIET = "PlausResid", "PlausFar", "PlausCalm", "PlausQuiet"


@dataclass(frozen=True)
class Relation:
    """One checked input: its held value, the constant names of its intercept, of each other input's slope (with
    that input's held value), of its gate and of the difference inside which it agrees again."""
    held: str
    intercept: str
    slopes: tuple[tuple[str, str], ...]  # (held value of the other input, slope constant)
    gate: str
    quiet: str


@dataclass(frozen=True)
class Check:
    relations: tuple[Relation, ...]
    constants: dict  # name -> binary32 value
    comments: dict  # name -> what it is


def check_region(check: Check) -> Region:
    """Once the block runs: set SensorsDisagree where an input is further than its gate from what the others say;
    clear it after c_SettleCalls calls on which every input is inside its quiet difference."""
    tests = [Assign(FAR, BoolConst(False)), Assign(CALM, BoolConst(True))]
    for r in check.relations:
        expected = reduce(lambda total, term: BinOp("+", total, BinOp("*", Ref(term[1]), Ref(term[0]))), r.slopes,
                          Ref(r.intercept))
        tests += [Assign(RESIDUAL, Call("ABS", (BinOp("-", Ref(r.held), expected),))),
                  If(((BinOp(">", Ref(RESIDUAL), Ref(r.gate)), (Assign(FAR, BoolConst(True)),)),)),
                  If(((Unary("NOT", BinOp("<=", Ref(RESIDUAL), Ref(r.quiet))), (Assign(CALM, BoolConst(False)),)),))]
    settle = (Assign(QUIET, BinOp("+", Ref(QUIET), Ref("c_OneCall"))),
              If(((BinOp(">=", Ref(QUIET), Ref("c_SettleCalls")), (Assign(DISAGREE_OUTPUT, BoolConst(False)),
                                                                 Assign(QUIET, IntConst(0)))),)))
    tests.append(If((
        (Ref(FAR), (Assign(DISAGREE_OUTPUT, BoolConst(True)), Assign(QUIET, IntConst(0)))),
        (Ref(DISAGREE_OUTPUT), (If(((Ref(CALM), settle),), orelse=(Assign(QUIET, IntConst(0)),)),)),
    )))
    return Region("Plausibility: each temperature against what the others say it should read",
                  (If(((Ref(READY_OUTPUT), tuple(tests)),)),))


def declarations() -> dict:
    """The output, static and temporaries the check adds."""
    return {"outputs": (Var(DISAGREE_OUTPUT, "BOOL", "a temperature differs from what the others say by more than "
                                                     "its gate (twice the recording's largest difference): one of them "
                                                     "is failing (the outputs are held as for a fault bit); wire it to "
                                                     "a message"),),
            "statics": (Var(QUIET, "INT", "calls in a row every temperature agreed with the others again"),),
            "temps": (Var(RESIDUAL, "REAL", "|a temperature minus what the others say it should read|, K"),
                      Var(FAR, "BOOL", "some temperature is beyond its gate in this call"),
                      Var(CALM, "BOOL", "every temperature is inside its quiet difference in this call"))}
