"""What an ST operation means, shared by both engines (verifier/engines/interpreter.py and the C of
verifier/engines/native.py): integer literal and result kinds, the loop bounds, which functions are portable,
and the errors and findings a run reports."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thermoplc.base.binary32 import INT_RANGES
from thermoplc.base.errors import UserError
from thermoplc.verifier.reading import syntax as s

MAX_LOOP_ITERATIONS = 1_000_000
MAX_REPLAY_LOOP_ITERATIONS = 50_000_000  # the interpreter's whole replay: about a minute, never hours
PORTABLE_REAL_FUNCTIONS = {"ABS", "SQRT", "MIN", "MAX"}
NON_PORTABLE_FUNCTIONS = {"EXP": np.exp, "LN": np.log, "LOG": np.log10, "SIN": np.sin, "COS": np.cos,
                          "TAN": np.tan, "ASIN": np.arcsin, "ACOS": np.arccos, "ATAN": np.arctan}
CONVERSIONS = {"INT_TO_REAL", "DINT_TO_REAL"}


def literal_kind(value: int) -> str:
    """An integer literal is an INT when it fits one, else a DINT (as TIA SCL types it by its value)."""
    lo, hi = INT_RANGES["INT"]
    return "INT" if lo <= value <= hi else "DINT"


def int_result_kind(left: str, right: str) -> str:
    """The type an integer operation is computed in: DINT when an operand is one, else INT. TIA SCL computes
    INT with INT in 16 bits and CODESYS in 32, so an INT intermediate beyond INT is read two ways: it is
    checked against INT and reported as an overflow."""
    return "DINT" if "DINT" in (left, right) else "INT"


class InterpretError(UserError):
    pass


class BlockFailure(InterpretError):
    """The block itself fails on a call: an index outside its array, an integer division by zero, a
    temp read before it is written, a FOR step of 0, a loop that would overrun any cycle. A block
    that does so is not its model (verify: exit 1), not a bad input; other callers see an error."""


class _Unset:
    def __repr__(self):
        return "<unset>"


UNSET = _Unset()


@dataclass
class Finding:
    kind: str  # subnormal, nan, inf, non-portable, literal, int-overflow
    pos: s.Pos
    detail: str
    count: int = 0
    first_cycle: int | None = None
