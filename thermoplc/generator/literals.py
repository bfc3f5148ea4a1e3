"""The one function that prints REAL literals (numeric contract rule 3).

A literal must name the same binary32 whether a compiler parses it straight to binary32 or
parses it to binary64 first and rounds again, and it should be the shortest text doing so,
so a reviewer reads `0.1` rather than `0.100000001`.
"""
from __future__ import annotations

import math

from thermoplc.base.binary32 import decimal_to_f32, f32_bits, is_f32, round_f32

MAX_DIGITS = 9  # nine significant digits always identify a binary32 value


def _names_value(text: str, bits: int) -> bool:
    """Both routes give `bits`; the exact (slow) route only for a text the quick one accepts."""
    return f32_bits(round_f32(float(text))) == bits and f32_bits(decimal_to_f32(text)) == bits


def _layout(digits: str, exponent: int, negative: bool) -> str:
    """Render significant digits d1.d2d3... x 10^exponent with a digit on both sides of the point."""
    digits = digits.rstrip("0") or "0"
    sign = "-" if negative else ""
    if -5 <= exponent < 8:
        if exponent >= 0:
            whole = (digits + "0" * (exponent + 1))[: exponent + 1]
            frac = digits[exponent + 1 :] or "0"
        else:
            whole = "0"
            frac = "0" * (-exponent - 1) + digits
        return f"{sign}{whole}.{frac}"
    frac = digits[1:] or "0"
    return f"{sign}{digits[0]}.{frac}E{exponent}"


def real_literal(value: float) -> str:
    """Shortest decimal text naming the binary32 `value` by both parse routes."""
    if not math.isfinite(value) or not is_f32(value):
        raise ValueError(f"{value!r} is not a finite binary32 value")
    negative = math.copysign(1.0, value) < 0
    if value == 0.0:
        return "-0.0" if negative else "0.0"
    bits = f32_bits(value)
    magnitude = abs(value)
    for count in range(1, MAX_DIGITS + 1):
        mantissa_text, exponent_text = f"{magnitude:.{count - 1}e}".split("e")
        mantissa = int(mantissa_text.replace(".", ""))
        exponent = int(exponent_text)
        best = None
        for candidate in (mantissa, mantissa - 1, mantissa + 1):
            if candidate <= 0 or len(str(candidate)) != count:
                continue
            text = _layout(str(candidate), exponent, negative)
            if _names_value(text, bits):
                error = abs(float(text) - value)
                if best is None or error < best[0]:
                    best = (error, text)
        if best is not None:
            return best[1]
    raise AssertionError(f"no {MAX_DIGITS}-digit literal names {value!r}")
