"""Text files as editors save them: UTF-8, or the encoding a byte order mark names (TIA Portal
exports UTF-8 with a mark; editors and PLCopen exporters save UTF-16 with one)."""
from __future__ import annotations

import codecs

from thermoplc.base.errors import UserError

# UTF-32 LE starts as UTF-16 LE does: the longer mark is tried first
BYTE_ORDER_MARKS = ((codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"), (codecs.BOM_UTF8, "utf-8-sig"),
                    (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16"))


def encoding_of(raw: bytes) -> str:
    return next((name for mark, name in BYTE_ORDER_MARKS if raw.startswith(mark)), "utf-8")


def decode(raw: bytes, path: str, expected: str) -> str:
    """The text of `raw`, or a UserError at the line and character where it stops being text of its
    encoding; `expected` says what the file should be."""
    encoding = encoding_of(raw)
    try:
        return raw.decode(encoding)
    except UnicodeDecodeError as exc:
        before = raw[:exc.start].decode(encoding, "replace")
        line, column = before.count("\n") + 1, len(before) - (before.rfind("\n") + 1) + 1
        name = encoding.upper().removesuffix("-SIG")
        found = (f"the file ends inside a character ({len(raw) - exc.start} byte(s) left over)"
                 if exc.end >= len(raw) and "truncated" in exc.reason else
                 f"{' '.join(f'0x{b:02X}' for b in raw[exc.start:exc.end])} is not {name} text")
        raise UserError(f"{path}:{line}:{column}: {found}; {expected} in UTF-8, or in UTF-16/32 with a byte "
                        f"order mark") from None


def decode_lenient(raw: bytes) -> str:
    """As `decode`, a damaged character replaced: for reading a header, not for proving anything."""
    return raw.decode(encoding_of(raw), "replace")
