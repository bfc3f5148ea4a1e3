"""numeric contract rule 3: a literal names the same binary32 by both parse routes and is as short as possible."""
import math

import numpy as np
from hypothesis import given, settings, strategies as st

from thermoplc.base.binary32 import decimal_to_f32, f32_bits, f32_from_bits, round_f32
from thermoplc.generator.literals import real_literal
from thermoplc.verifier.reading.parser import parse_text

finite_f32 = st.integers(0, 2 ** 32 - 1).map(f32_from_bits).filter(math.isfinite)


@given(finite_f32)
@settings(max_examples=400, deadline=None)
def test_literal_round_trips_by_both_routes(value):
    text = real_literal(value)
    assert f32_bits(decimal_to_f32(text)) == f32_bits(value)
    assert np.float32(float(text)).view(np.uint32) == np.uint32(f32_bits(value))
    assert f32_bits(round_f32(float(text))) == f32_bits(value)


@given(finite_f32)
@settings(max_examples=200, deadline=None)
def test_literal_shape_is_st_real(value):
    text = real_literal(value)
    mantissa = text.lstrip("-").split("E")[0]
    whole, point, frac = mantissa.partition(".")
    assert point and whole.isdigit() and frac.isdigit(), text
    assert "e" not in text and "+" not in text


@given(finite_f32)
@settings(max_examples=200, deadline=None)
def test_literal_is_no_longer_than_the_shortest_direct_round_trip(value):
    digits = lambda t: len(t.lstrip("-").split("E")[0].replace(".", "").strip("0"))
    shortest = np.format_float_scientific(np.float32(value), unique=True, trim="-")
    assert digits(real_literal(value)) <= max(1, digits(shortest.split("e")[0])) + 1


@given(finite_f32)
@settings(max_examples=150, deadline=None)
def test_literal_parses_back_through_the_st_grammar(value):
    program = parse_text(f"FUNCTION_BLOCK B\nVAR CONSTANT\n c : REAL := {real_literal(value)};\nEND_VAR\nEND_FUNCTION_BLOCK")
    assert f32_bits(program.decls[0].initial) == f32_bits(value)


def test_known_literals():
    cases = {0.1: "0.1", 1.0: "1.0", -2.5: "-2.5", 1e-30: "1.0E-30", 100000000.0: "1.0E8", 0.001: "0.001",
             3.4028234663852886e38: "3.4028235E38", 1e-45: "1.0E-45", -0.0: "-0.0", 1234567.0: "1234567.0"}
    for value, text in cases.items():
        assert real_literal(round_f32(value)) == text


def test_non_finite_values_have_no_literal():
    for bad in (math.inf, -math.inf, math.nan):
        try:
            real_literal(bad)
        except ValueError:
            continue
        raise AssertionError(f"{bad} printed")
