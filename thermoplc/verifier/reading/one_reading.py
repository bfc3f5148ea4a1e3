"""ST text that compilers read in more than one way is refused before it is parsed.

The verifier's grammar ends a `//` comment at LF and a block comment at its first closer. Other
tools differ exactly there: CODESYS and TwinCAT nest `(* (* *) *)` comments, so a comment opened
inside a comment hides or reveals the code after the first closer; a lone CR, a form feed or a
Unicode line separator ends a `//` comment for some editors and importers and not for others; a
`{IF ...}` pragma keeps one branch for a compiler and none for the grammar, which skips braces. A
proof about one reading says nothing about the other, so such text is named at its line and
column, never read one way.
"""
from __future__ import annotations

import re

from thermoplc.base.errors import UserError
from thermoplc.verifier.reading.syntax import position

LINE_BREAKS = {"\r": "carriage return without a line feed", "\x0b": "vertical tab", "\x0c": "form feed",
               "\x85": "next-line character", "\u2028": "Unicode line separator",
               "\u2029": "Unicode paragraph separator"}
_BREAK = re.compile("\r(?!\n)|[\x0b\x0c\x85\u2028\u2029]")
_COMMENT_MARK = re.compile(r"(?=(//|\(\*|\*\)|/\*|\*/|\n|\{))")
# pragmas that choose code at compile time: the verifier's grammar skips every {...}, so it would run
# every branch where a compiler runs one
_CONDITIONAL = re.compile(r"\{\s*(IF|ELSIF|ELSE|END_IF|DEFINE|UNDEFINE)\b", re.IGNORECASE)
_CLOSER = {"(*": "*)", "/*": "*/"}


def _pragma_end(text: str, start: int, source: str) -> int:
    """Where the pragma opened at `start` ends; a conditional-compilation pragma is refused."""
    if _CONDITIONAL.match(text, start):
        line, column = position(text, start)
        raise UserError(f"{source}:{line}:{column}: a conditional-compilation pragma ({text[start:start + 20]!r}...): "
                        f"a compiler keeps one branch, the verifier would read them all; expected no {{IF}} pragmas")
    close = text.find("}", start)
    return len(text) if close < 0 else close + 1


def refuse_two_readings(text: str, source: str) -> None:
    """A UserError at the first place where tools read `text` differently, or None."""
    found = _BREAK.search(text)
    if found:
        line, column = position(text, found.start())
        char = found.group()
        raise UserError(f"{source}:{line}:{column}: a {LINE_BREAKS[char]} (U+{ord(char):04X}): tools disagree "
                        f"whether it ends a line, and so a // comment; expected lines ending in LF or CRLF")
    opened, in_line_comment, end = None, False, 0
    for mark in _COMMENT_MARK.finditer(text):  # every place a mark starts, overlapping ones too ('//*')
        start, token = mark.start(), mark.group(1)
        if start < end:
            continue  # inside a mark already taken
        if in_line_comment:
            in_line_comment, end = (False, start + 1) if token == "\n" else (True, end)
        elif opened is None:
            if token == "//":
                in_line_comment, end = True, start + 2
            elif token in _CLOSER:
                opened, end = token, start + 2
            elif token == "{":  # a pragma or attribute: opaque to the grammar, so markers inside mean nothing
                end = _pragma_end(text, start, source)
        elif token in _CLOSER:
            line, column = position(text, start)
            raise UserError(f"{source}:{line}:{column}: {token} inside a {opened} comment: compilers disagree "
                            f"whether comments nest (CODESYS and TwinCAT nest them), so the code after the "
                            f"first {_CLOSER[opened]} is read two ways; close the comment first")
        elif token == _CLOSER[opened]:
            opened, end = None, start + 2
