"""ST text is read one way or refused (verifier/reading/one_reading.py): whatever it accepts, a compiler that nests
comments and one that does not, one that ends a // comment at any line break and one that ends it at LF
only, all keep the same code."""
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from thermoplc.base.errors import UserError
from thermoplc.verifier.reading.one_reading import refuse_two_readings

PIECES = ("(*", "*)", "/*", "*/", "//", "\n", "\r\n", "\r", "\x0c", "\u2028", "x", " ", "*", "(", "/", ")")
OPENERS = {"(*": "*)", "/*": "*/"}


def code_of(text: str, nested: bool, breaks: tuple[str, ...]) -> str:
    """The text with its comments removed, as a compiler with these rules reads it."""
    out, k, closers = [], 0, []
    while k < len(text):
        two = text[k:k + 2]
        if closers:
            if two == closers[-1]:
                closers.pop()
                k += 2
            elif nested and two in OPENERS:
                closers.append(OPENERS[two])
                k += 2
            else:
                k += 1
        elif two == "//":
            k += 2
            while k < len(text) and not any(text.startswith(b, k) for b in breaks):
                k += 1
        elif two in OPENERS:
            closers.append(OPENERS[two])
            k += 2
        else:
            out.append(text[k])
            k += 1
    return "".join(out)


@settings(max_examples=400, deadline=None)
@given(st.lists(st.sampled_from(PIECES), max_size=30).map("".join))
def test_accepted_text_keeps_the_same_code_under_every_reading(text):
    try:
        refuse_two_readings(text, "t.st")
    except UserError:
        return
    readings = {" ".join(code_of(text, nested, breaks).split()) for nested in (False, True)  # tokens, not spaces
                for breaks in (("\n",), ("\n", "\r", "\x0c", "\u2028"))}
    assert len(readings) == 1, (text, readings)


@pytest.mark.parametrize("text, place", [("(* a (* b *) c *)", "1:6"), ("/* /* */ */", "1:4"),
                                         ("x // y\rz", "1:7"), ("(* ok *)\n// \u2028", "2:4"),
                                         ("{info '//'} (* x (* y *)\nM := 1;\n// *)", "1:18"),
                                         ("x := 1;\n{IF defined(never)}\nx := 2;\n{END_IF}", "2:1"),
                                         ("{ elsif x }", "1:1")])
def test_the_first_place_read_two_ways_is_named(text, place):
    with pytest.raises(UserError, match=f"t.st:{place}: "):
        refuse_two_readings(text, "t.st")


def test_plain_comments_attributes_and_windows_line_ends_are_read():
    refuse_two_readings("{ S7_Optimized_Access := 'TRUE' }\nx := 1; (* a *) // b\r\n/* c\r\n */ y := 2; "
                        "// (* not a comment opener here\n{attribute 'qualified_only'} (* {IF} in a comment *)", "t.st")
