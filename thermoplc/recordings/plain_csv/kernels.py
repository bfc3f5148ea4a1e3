"""The compiled loops of the plain-number CSV parser (numba; imported only when a block is parsed, so
the model registry, which imports every module of models/, loads no numba). See the package's docstring."""
from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba import uint64 as u64
from numba.core.extending import intrinsic
from numba.cpython.unsafe.numbers import trailing_zeros

from thermoplc.base.compiled import njit

_NEWLINE = ord("\n")

POWERS = np.array([10.0 ** k for k in range(23)])  # exact doubles
INTEGER_POWERS = np.array([10 ** k for k in range(20)], np.uint64)
_EXACT = 1 << 53  # integers up to here are exact doubles
_ZEROS = np.uint64(0x3030303030303030)  # '0' in each byte
_HIGH = np.uint64(0xF0F0F0F0F0F0F0F0)
_SIXES = np.uint64(0x0606060606060606)
_PAIRS = np.uint64(0x000000FF000000FF)
_HUNDREDS = np.uint64(100 + (1000000 << 32))
_ONES = np.uint64(1 + (10000 << 32))
_MINUS, _BYTE = 45, np.uint64(0xFF)

@intrinsic
def _load8(typingctx, data, at):
    """The 8 bytes of `data` from byte `at` as one little-endian integer (an unaligned load; the buffer's padding
    keeps it inside). numba's indexing would check each byte for a negative index, which stops LLVM from joining
    the eight loads into one."""
    def codegen(context, builder, signature, args):
        array = context.make_array(signature.args[0])(context, builder, args[0])
        pointer = builder.bitcast(builder.gep(array.data, [args[1]]), ir.IntType(64).as_pointer())
        return builder.load(pointer, align=1)
    return types.uint64(data, at), codegen


@njit
def _leading_digits(word):
    """How many of the word's bytes, from the first, are ASCII digits (8: all)."""
    other = ((word & _HIGH) ^ _ZEROS) | (((word + _SIXES) & _HIGH) ^ _ZEROS)
    if other == u64(0):
        return 8
    return np.int64(trailing_zeros(other)) >> 3


@njit
def _digits_value(word, count):
    """The number the first `count` (1-8) digit bytes of the word write: shifted so the digits fill the top bytes
    (zeros below them), then pairs, fours and eights of digits are joined by three multiplications."""
    word = (word - _ZEROS) << u64(8 * (8 - count))
    word = word * u64(10) + (word >> u64(8))
    return (((word & _PAIRS) * _HUNDREDS) + (((word >> u64(16)) & _PAIRS) * _ONES)) >> u64(32)


@njit
def _long_cell(data, at, point, powers, out, slot, row):
    """A cell of more than 7 digits before or 6 after the point, one byte at a time, into out[slot, row] (slot -1:
    only checked): the position after it, or -1 when it is not a plain number with an exact fast path."""
    negative = data[at] == _MINUS
    at += negative
    mantissa = u64(0)
    digits = 0
    scale = -1
    while True:
        byte = data[at]
        if 48 <= byte <= 57:
            if digits == 19:
                return -1
            mantissa = mantissa * u64(10) + u64(byte - 48)
            digits += 1
            if scale >= 0:
                scale += 1
        elif byte == point and scale < 0 and digits > 0:
            scale = 0
        else:
            break
        at += 1
    if digits == 0 or scale == 0 or scale > 22 or mantissa > u64(_EXACT):
        return -1
    if slot >= 0:
        value = np.float64(mantissa) / powers[max(scale, 0)]
        out[slot, row] = -value if negative else value
    return at


@njit
def parse_rows(data, start, stop, delimiter, point, powers, integer_powers, slots, out):
    """Rows of the lines from data[start] into out[slot, row], until `stop` or `out` is full: (their count, where the
    next line starts), or (-1, the cell's position) when a line is not plain. Column c goes to out[slots[c]]; a column
    whose slot is -1 is only checked (its numbers are not needed, but a cell that is not a number must still be seen)."""
    columns = slots.shape[0]
    at = start
    row = 0
    while at < stop and row < out.shape[1]:
        for column in range(columns):
            negative = (_load8(data, at) & _BYTE) == u64(_MINUS)
            begin = at
            at += negative
            word = _load8(data, at)
            count = _leading_digits(word)
            if count == 0:
                return -1, begin
            mantissa = _digits_value(word, min(count, 7))
            at += count
            word = _load8(data, at)
            scale = 0
            if (word & _BYTE) == u64(point):
                word = word >> u64(8)
                scale = _leading_digits(word | (_BYTE << u64(56)))  # 7 bytes after the point
                if scale == 0:
                    return -1, begin
                mantissa = mantissa * integer_powers[min(scale, 6)] + _digits_value(word, min(scale, 6))
                at += scale + 1
                word = _load8(data, at)
            slot = slots[column]
            if count < 8 and scale < 7:
                if slot >= 0:
                    value = np.float64(mantissa) / powers[scale]
                    out[slot, row] = -value if negative else value
            else:
                at = _long_cell(data, begin, point, powers, out, slot, row)
                if at < 0:
                    return -1, begin
                word = _load8(data, at)
            end = _NEWLINE if column == columns - 1 else delimiter
            if (word & _BYTE) != u64(end):
                return -1, begin
            at += 1
        row += 1
    return row, at
