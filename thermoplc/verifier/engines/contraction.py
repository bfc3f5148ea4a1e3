"""What a target that contracts multiply-adds shows: the block replayed with every a*b+c, a*b-c and c-a*b
of one expression rounded once (as aarch64 gcc -O2 and x86 -ffp-contract=fast build OpenPLC's C), compared
with the float32 reference. A replay, not a proof: a compiler that fuses only some of the pairs, or a
product stored in a variable with the sum in the next statement, may differ by another amount."""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from thermoplc.base.binary32 import FLT_MIN_NORMAL, fraction_to_f32
from thermoplc.contract.outputs import output_unit
from thermoplc.verifier.reading import syntax as s
from thermoplc.verifier.engines.interpreter import Machine
from thermoplc.verifier.engines.semantics import BlockFailure

MAX_CALLS = 20_000  # the interpreter's pace (about 10,000 calls/s): a longer recording is judged on its first calls (said)


def fused(a: float, b: float, c: float) -> float:
    """a*b + c rounded once to binary32, as fmaf gives it: the product of two binary32 values is exact in
    binary64, the sum rounded to binary64 and then to binary32 is the same unless the binary64 sum is a
    binary32 tie (or below binary32's normal range): then the exact sum is rounded."""
    r = a * b + c
    bits = struct.unpack("<Q", struct.pack("<d", r))[0]
    if r != r or abs(r) == math.inf or (abs(r) >= FLT_MIN_NORMAL and bits & 0x1FFFFFFF != 0x10000000):
        return r
    if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(c)):
        return r
    return fraction_to_f32(Fraction(a) * Fraction(b) + Fraction(c), negative_zero=r == 0 and math.copysign(1, r) < 0)


class ContractingMachine(Machine):
    """The interpreter with each REAL multiply-add of one expression rounded once (`fused`); where both
    operands of the sum are products, the left one is fused."""

    def _binop(self, e: s.BinOp):
        if e.op in ("+", "-"):
            fused = self._fused(e)
            if fused is not None:
                return fused
        return super()._binop(e)

    def _fused(self, e: s.BinOp):
        for product, other, product_first in ((e.left, e.right, True), (e.right, e.left, False)):
            if not (isinstance(product, s.BinOp) and product.op == "*"):
                continue
            (af, ak), (bf, bk), (cf, ck) = (self._expr(product.left), self._expr(product.right), self._expr(other))
            if not ak == bk == ck == "REAL":
                return None
            rnd = self._round(e.pos, f"fused '{e.op}'")
            if e.op == "+":
                return (lambda v: rnd(fused(af(v), bf(v), cf(v)))), "REAL"
            if product_first:
                return (lambda v: rnd(fused(af(v), bf(v), -cf(v)))), "REAL"
            return (lambda v: rnd(fused(-af(v), bf(v), cf(v)))), "REAL"
        return None


@dataclass(frozen=True)
class Contraction:
    """The largest |fused replay - reference| of each REAL output over the calls replayed."""
    deviation: dict
    calls: int
    rows: int
    failure: str = ""  # the fused replay stopped (a run-time error it met)

    def line(self) -> str:
        if self.failure:
            return f"contraction (a*b+c fused, as OpenPLC on aarch64 builds it): the fused replay stops: {self.failure}"
        shown = ", ".join(f"{name} {value:.3g} {output_unit(name)}" for name, value in self.deviation.items())
        over = f"{self.calls:,} calls" + (f" (the first of {self.rows:,})" if self.calls < self.rows else "")
        return (f"contraction: a target that fuses each a*b+c into one rounding (OpenPLC on aarch64, gcc -O2) differs "
                f"by at most {shown} over {over}: a replay with every multiply-add of an expression fused, not a "
                f"proof (docs/commissioning.md); testbench --tolerance-um takes it")



class ContractionRun:
    """The fused replay fed chunk by chunk (a streamed recording) or at once."""

    def __init__(self, program: s.Program, source: str, rows: int):
        self.machine = ContractingMachine(program, source)
        self.reals = [d.name for d in self.machine.outputs if d.type.base == "REAL" and not d.type.bounds]
        self.deviation = dict.fromkeys(self.reals, 0.0)
        self.calls, self.rows, self.failure = 0, rows, ""

    def feed(self, columns: dict, expected: dict, rows: int) -> None:
        rows = min(rows, MAX_CALLS - self.calls)
        if rows <= 0 or self.failure:
            return
        try:
            produced = self.machine.replay({k: np.asarray(v[:rows]).tolist() for k, v in columns.items()}, rows,
                                           tuple(self.reals))
        except BlockFailure as exc:
            self.failure = str(exc)
            return
        for name in self.reals:
            got = np.asarray(produced[name], np.float64)
            want = np.asarray(expected[name][:rows], np.float64)
            with np.errstate(invalid="ignore"):
                gap = np.abs(got - want)
            worst = float(np.inf if np.isnan(gap).any() else np.max(gap)) if len(gap) else 0.0  # NaN: no bound
            self.deviation[name] = max(self.deviation[name], worst)
        self.calls += rows

    def result(self) -> Contraction:
        return Contraction(dict(self.deviation), self.calls, self.rows, self.failure)


def contraction(program: s.Program, source: str, columns: dict, expected: dict, rows: int) -> Contraction:
    """The fused replay of a whole recording (its first MAX_CALLS calls)."""
    run = ContractionRun(program, source, rows)
    run.feed(columns, expected, rows)
    return run.result()
