"""Choose how a block is replayed: the interpreter (the reference semantics) or the native engine.

`auto` runs natively when a C compiler is there and the block has only portable operations,
and replays with the interpreter whenever the native run meets anything the interpreter would
report (NaN, Inf, subnormal, INT overflow, a temp read before it is written), so findings and
error messages are always the interpreter's.
"""
from __future__ import annotations

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.verifier.reading import syntax as s
from thermoplc.verifier.engines.interpreter import Machine
from thermoplc.verifier.engines.native import native_or_reason

ENGINES = ("auto", "interp", "fast")


class Replayer:
    def __init__(self, program: s.Program, source: str, engine: str = "auto"):
        if engine not in ENGINES:
            raise UserError(f"unknown engine {engine!r}; expected one of {', '.join(ENGINES)}")
        self.machine = Machine(program, source)
        self.native = None
        self.used = "interp"
        self.note = ""
        if engine != "interp":
            self.native, reason = native_or_reason(program)
            if self.native is None:
                if engine == "fast":
                    raise UserError(f"{source}: the fast engine is not available: {reason}")
                self.note = f"fast engine not available ({reason}); replayed with the interpreter"

    @property
    def inputs(self) -> list:
        return self.machine.inputs

    @property
    def outputs(self) -> list:
        return self.machine.outputs

    def replay(self, columns: dict, rows: int, outputs: tuple[str, ...]) -> dict:
        """Outputs by name, one value per row, the block starting from its initial state. An input
        without a column keeps its declared start value (an unwired Enable or Reset)."""
        if self.native is not None:
            self.native.reset()
            result = self.native.run(columns, rows)
            if result is not None and not result[1]:
                self.used = "fast"
                return {name: result[0][name] for name in outputs}
            self.note = ("the fast engine met a value the interpreter reports (NaN, Inf, subnormal, INT overflow, "
                         "an unset temp, an index outside its array); replayed with the interpreter")
        self.used = "interp"
        self.machine.reset()
        lists = {name: np.asarray(col).tolist() for name, col in columns.items()}
        return self.machine.replay(lists, rows, outputs=outputs)
