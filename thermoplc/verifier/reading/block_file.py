"""A block file read into the AST: its bytes within the size a block may have, decoded (UTF-8 or as its
byte order mark says), then parsed as Structured Text or, when it is the PLCopen XML `generate --format
plcopen` writes, read by verifier/reading/plcopen.py (which parses its bodies with verifier/reading/parser.py)."""
from __future__ import annotations

from pathlib import Path

from thermoplc.base.errors import unreadable
from thermoplc.base.text import decode, encoding_of
from thermoplc.verifier.reading import syntax as s
from thermoplc.verifier.reading.parser import MAX_SOURCE_CHARACTERS, StSyntaxError, parse_text
from thermoplc.verifier.reading.plcopen import is_xml, read_plcopen

def _source_bytes(path: str) -> bytes:
    """A block file's bytes, within the size a block may have."""
    try:
        if Path(path).stat().st_size > 4 * MAX_SOURCE_CHARACTERS:
            raise StSyntaxError(f"{path}: {Path(path).stat().st_size:,} bytes; a function block source is at most "
                                f"{MAX_SOURCE_CHARACTERS:,} here (characters)")
        return Path(path).read_bytes()
    except OSError as exc:
        raise unreadable(path, exc, "the block") from None


def _decoded(raw: bytes, path: str) -> str:
    return decode(raw, path, "a block is read as Structured Text or PLCopen XML")


def read_source(path: str) -> str:
    """A block file's text (UTF-8, or as its byte order mark says), within the size a block may have."""
    return _decoded(_source_bytes(path), path)


def parse_file(path: str | Path) -> s.Program:
    path = str(path)
    raw = _source_bytes(path)
    text = _decoded(raw, path)
    if is_xml(text) or path.lower().endswith(".xml"):  # the PLCopen XML of generate --format plcopen
        return read_plcopen(text, path, encoding_of(raw))
    return parse_text(text, path)
