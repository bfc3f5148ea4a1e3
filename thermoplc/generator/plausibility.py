"""The cross-sensor check's statements: SensorsDisagree when a held temperature differs from what the other
temperatures say by more than its gate, or that difference leaves its slow mean by more than its swing gate,
until they agree again for c_SettleCalls calls. Knows the IR, not the models: the caller names, per checked input, the
variable holding its good value and the constants of its relation; models/plausibility.py computes the same
operations in the same order.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import reduce

from thermoplc.contract.outputs import DISAGREE_OUTPUT, READY_OUTPUT
from thermoplc.generator.ir import Assign, BinOp, BoolConst, Call, If, IntConst, Ref, Region, Unary, Var

RESIDUAL, FAR, CALM, QUIET = "PlausResid", "PlausFar", "PlausCalm", "PlausQuiet"
DIFFERENCE, DEVIATION, STARTED = "PlausDiff", "PlausDev", "PlausStarted"


@dataclass(frozen=True)
class Relation:
    """One checked input: its held value, the constant names of its intercept, of each other input's slope (with
    that input's held value), of its gate and of the difference inside which it agrees again."""
    held: str
    intercept: str
    slopes: tuple[tuple[str, str], ...]  # (held value of the other input, slope constant)
    gate: str | None  # None: no level test (a relation without slopes)
    quiet: str | None
    swing: tuple[str, str, str] | None  # the swing gate's and swing quiet's constants, the slow mean's static
    label: str = ""  # the input's name, for the comments


@dataclass(frozen=True)
class Check:
    relations: tuple[Relation, ...]
    constants: dict  # name -> binary32 value
    comments: dict  # name -> what it is
    factors: tuple[str, str] | None = None  # the slow means' keep and alpha constants (with the swing test)


def check_region(check: Check) -> Region:
    """Once the block runs: set SensorsDisagree where an input is further than its gate from what the others say;
    clear it after c_SettleCalls calls on which every input is inside its quiet difference."""
    tests = [Assign(FAR, BoolConst(False)), Assign(CALM, BoolConst(True))]
    for r in check.relations:
        expected = reduce(lambda total, term: BinOp("+", total, BinOp("*", Ref(term[1]), Ref(term[0]))), r.slopes,
                          Ref(r.intercept))
        tests += [Assign(DIFFERENCE, BinOp("-", Ref(r.held), expected)),
                  *(_beyond(DIFFERENCE, r.gate, r.quiet) if r.gate else ())]
        if r.swing:
            gate, quiet, mean = r.swing
            keep, alpha = check.factors
            tests += [If(((Unary("NOT", Ref(STARTED)), (Assign(mean, Ref(DIFFERENCE)),)),)),
                      Assign(DEVIATION, BinOp("-", Ref(DIFFERENCE), Ref(mean))),
                      Assign(mean, BinOp("+", BinOp("*", Ref(keep), Ref(mean)), BinOp("*", Ref(alpha), Ref(DIFFERENCE)))),
                      *_beyond(DEVIATION, gate, quiet)]
    if check.factors:
        tests.append(Assign(STARTED, BoolConst(True)))
    settle = (Assign(QUIET, BinOp("+", Ref(QUIET), Ref("c_OneCall"))),
              If(((BinOp(">=", Ref(QUIET), Ref("c_SettleCalls")), (Assign(DISAGREE_OUTPUT, BoolConst(False)),
                                                                 Assign(QUIET, IntConst(0)))),)))
    tests.append(If((
        (Ref(FAR), (Assign(DISAGREE_OUTPUT, BoolConst(True)), Assign(QUIET, IntConst(0)))),
        (Ref(DISAGREE_OUTPUT), (If(((Ref(CALM), settle),), orelse=(Assign(QUIET, IntConst(0)),)),)),
    )))
    return Region("Plausibility: each temperature against what the others say it should read",
                  (If(((Ref(READY_OUTPUT), tuple(tests)),)),))


def _beyond(value: str, gate: str, quiet: str) -> tuple:
    """FAR where |value| is beyond its gate; CALM cleared where it is not inside its quiet difference."""
    return (Assign(RESIDUAL, Call("ABS", (Ref(value),))),
            If(((BinOp(">", Ref(RESIDUAL), Ref(gate)), (Assign(FAR, BoolConst(True)),)),)),
            If(((Unary("NOT", BinOp("<=", Ref(RESIDUAL), Ref(quiet))), (Assign(CALM, BoolConst(False)),)),)))


def declarations(check: Check) -> dict:
    """The output, statics and temporaries the check adds."""
    swings = [r for r in check.relations if r.swing]
    return {"outputs": (Var(DISAGREE_OUTPUT, "BOOL", "a temperature differs from what the others say by more than "
                                                     "its gate (twice the recording's largest difference)"
                                                     + (", or that difference swings faster than recorded" if swings
                                                        else "") + ": one of them is failing (the outputs are held as "
                                                     "for a fault bit); wire it to a message"),),
            "statics": (Var(QUIET, "INT", "calls in a row every temperature agreed with the others again"),
                        *((Var(STARTED, "BOOL", "the slow means have started (from the first running call)"),)
                          if swings else ()),
                        *(Var(r.swing[2], "REAL", f"slow mean of {r.label}'s difference from what the others say, K")
                          for r in swings)),
            "temps": (Var(DIFFERENCE, "REAL", "a temperature minus what the others say it should read, K"),
                      *((Var(DEVIATION, "REAL", "that difference minus its slow mean, K"),) if swings else ()),
                      Var(RESIDUAL, "REAL", "|the difference or its deviation|, K"),
                      Var(FAR, "BOOL", "some temperature is beyond its gate in this call"),
                      Var(CALM, "BOOL", "every temperature is inside its quiet difference in this call"))}
