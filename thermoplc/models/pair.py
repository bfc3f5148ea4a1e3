"""The model file's small sections (the known start, the envelope): their fields checked alike, and a fitted
constant as the file writes it — the float64 the fit found and the binary32 the block holds."""
from __future__ import annotations

import numpy as np

from thermoplc.base.binary32 import parse_f32_hex, round_f32
from thermoplc.base.errors import UserError


def constant_pair(entry, path: str, where: str) -> tuple[float, float]:
    """A constant of the model file as {"f64": number, "f32": "0x........"}, f32 the f64 rounded to binary32."""
    if not isinstance(entry, dict) or not isinstance(entry.get("f64"), (int, float)) or isinstance(entry.get("f64"), bool) \
            or not isinstance(entry.get("f32"), str):
        raise UserError(f"{path}: field {where!r}: expected {{\"f64\": number, \"f32\": \"0x........\"}}")
    if not np.isfinite(entry["f64"]):
        raise UserError(f"{path}: field '{where}.f64': {entry['f64']!r}; expected a finite number")
    try:
        f32 = parse_f32_hex(entry["f32"])
    except ValueError as exc:
        raise UserError(f"{path}: field '{where}.f32': {exc}") from None
    if f32 != round_f32(float(entry["f64"])):
        raise UserError(f"{path}: field {where!r}: f32 {entry['f32']} is not f64 {entry['f64']!r} rounded to binary32; "
                        f"edit f64 and let thermoplc write f32")
    return float(entry["f64"]), f32


def check_section(doc, path: str, section: str, fields: tuple[str, ...], what: str) -> dict:
    """`doc` as the section `section` with exactly `fields`, or a UserError naming the field; `what` says what a
    field of it is ('a constant of the start')."""
    if not isinstance(doc, dict):
        raise UserError(f"{path}: field '{section}': expected an object with {', '.join(fields)}")
    unknown = sorted(set(doc) - set(fields))
    if unknown:
        raise UserError(f"{path}: field '{section}.{unknown[0]}': not {what}; it has {', '.join(fields)}")
    missing = [name for name in fields if name not in doc]
    if missing:
        raise UserError(f"{path}: field '{section}.{missing[0]}' is missing")
    return doc
