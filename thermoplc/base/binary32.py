"""IEEE-754 binary32 helpers shared by the model files, the generator and the verifier.

Python floats are binary64. Rounding a binary64 sum, difference, product, quotient or square
root of two binary32 values to binary32 gives the correctly rounded binary32 result (53 >= 2*24+2),
so binary32 arithmetic is done as "binary64 operation, then `round_f32`".
"""
from __future__ import annotations

import array
import math
import struct
from fractions import Fraction

FLT_MAX = 3.4028234663852886e38
INT_RANGES = {"INT": (-32768, 32767), "DINT": (-(2 ** 31), 2 ** 31 - 1)}  # the integer types blocks use
FLT_MIN_NORMAL = 1.1754943508222875e-38
# the largest REAL as the S7 manuals write it (+-3.402823E+38): FLT_MAX's own shortest text, 3.4028235E38, lies
# beyond that, and a compiler that range-checks the literal text may refuse it
REAL_TEXT_MAX = 3.402823e38
FADE_FLOOR = 1e-6  # a state fading by a factor per call is set to 0 below this, before it becomes subnormal

_cell = array.array("f", [0.0])
_bits = struct.Struct("<f")
_word = struct.Struct("<I")


def round_f32(x: float) -> float:
    """Round a binary64 value to the nearest binary32 (ties to even); overflow gives ±inf."""
    _cell[0] = x
    return _cell[0]


def is_f32(x: float) -> bool:
    """True when `x` is exactly a binary32 value (NaN and the infinities included): rounding it changes nothing."""
    return math.isnan(x) or round_f32(x) == x


def f32_bits(x: float) -> int:
    """The 32-bit pattern of a binary32 value held in a Python float."""
    return _word.unpack(_bits.pack(round_f32(x)))[0]


def f32_from_bits(word: int) -> float:
    """The binary32 value with bit pattern `word` (0 to 0xFFFFFFFF) as a Python float; struct.error outside."""
    return _bits.unpack(_word.pack(word))[0]


def f32_hex(x: float) -> str:
    """`x` rounded to binary32, as its bit pattern: "0x" and 8 upper-case hex digits (the f32 form of model files)."""
    return f"0x{f32_bits(x):08X}"


def parse_f32_hex(text: str) -> float:
    """The binary32 value of a bit pattern written as "0x" and 8 hex digits (f32_hex's form); ValueError else."""
    if not (text.startswith("0x") and len(text) == 10):
        raise ValueError(f"expected 0x followed by 8 hex digits, found {text!r}")
    return f32_from_bits(int(text[2:], 16))


def ordered_key(word: int) -> int:
    """Map a binary32 bit pattern to an integer that is monotonic in the value (for ULP distance)."""
    return word if word < 0x80000000 else 0x80000000 - word


def ulp_distance(a: float, b: float) -> int:
    """Number of binary32 values between a and b (0 for identical bits; -0 and +0 are 1 apart)."""
    return abs(ordered_key(f32_bits(a)) - ordered_key(f32_bits(b)))


def is_subnormal(x: float) -> bool:
    """True for a nonzero value below binary32's least normal magnitude (about 1.18e-38): a binary32 subnormal."""
    return x != 0.0 and abs(x) < FLT_MIN_NORMAL


def fraction_to_f32(q: Fraction, negative_zero: bool = False) -> float:
    """Correctly rounded binary32 nearest to an exact rational (the direct parse route of §4.3)."""
    if q == 0:
        return -0.0 if negative_zero else 0.0
    sign = -1.0 if q < 0 else 1.0
    q = abs(q)
    exponent = q.numerator.bit_length() - q.denominator.bit_length()
    if q < Fraction(2) ** exponent:
        exponent -= 1
    exponent = max(exponent, -126)
    scaled = q * Fraction(2) ** (23 - exponent)
    mantissa = round(scaled)  # Fraction.__round__ rounds half to even
    value = Fraction(mantissa) * Fraction(2) ** (exponent - 23)
    if value >= Fraction(2) ** 128:
        return sign * math.inf
    return sign * float(value)


def decimal_to_f32(text: str) -> float:
    """Parse decimal text (digits, point, optional exponent) straight to binary32."""
    cleaned = text.strip()
    return fraction_to_f32(Fraction(cleaned), negative_zero=cleaned.startswith("-"))
