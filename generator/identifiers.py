"""Identifier rules of DESIGN §4.6, applied to every name that reaches emitted ST."""
from __future__ import annotations

import re

MAX_LENGTH = 24  # STEP 7 classic symbol limit
_SHAPE = re.compile(r"[A-Za-z](?:_?[A-Za-z0-9])*\Z")

_KEYWORDS = """
ACTION ANY ARRAY AT BEGIN BOOL BY BYTE CASE CHAR CONFIGURATION CONST CONSTANT CONTINUE DATA_BLOCK
DATE DATE_AND_TIME DINT DO DT DWORD ELSE ELSIF END_ACTION END_CASE END_CONFIGURATION END_CONST
END_DATA_BLOCK END_FOR END_FUNCTION END_FUNCTION_BLOCK END_IF END_LABEL END_ORGANIZATION_BLOCK
END_PROGRAM END_REGION END_REPEAT END_RESOURCE END_STEP END_STRUCT END_TRANSITION END_TYPE END_VAR
END_WHILE EN ENO EXIT FALSE FOR FROM FUNCTION FUNCTION_BLOCK GOTO IF INITIAL_STEP INT INTERVAL
LABEL LDATE LINT LREAL LTIME LWORD MOD NIL NON_RETAIN NOT OF ON OR ORGANIZATION_BLOCK PRIORITY
PROGRAM READ_ONLY READ_WRITE REAL REF REGION REPEAT RESOURCE RETAIN RETURN S5TIME SINT STEP
STRING STRUCT SUPER THEN THIS TIME TIME_OF_DAY TITLE TO TOD TRANSITION TRUE TYPE UDINT UINT ULINT
UNTIL USINT VAR VAR_ACCESS VAR_CONFIG VAR_EXTERNAL VAR_GLOBAL VAR_INPUT VAR_IN_OUT VAR_OUTPUT
VAR_TEMP VERSION VOID WCHAR WHILE WITH WORD WSTRING XOR AND AUTHOR FAMILY NAME KNOW_HOW_PROTECT
"""
_STANDARD_NAMES = """
ABS SQRT LN LOG EXP EXPT SIN COS TAN ASIN ACOS ATAN ATAN2 ADD SUB MUL DIV MOVE SEL MAX MIN LIMIT
MUX GT GE EQ LE LT NE SHL SHR ROL ROR LEN LEFT RIGHT MID CONCAT INSERT DELETE REPLACE FIND TRUNC
ROUND CEIL FLOOR FRAC NORM_X SCALE_X SCALE UNSCALE SR RS TP TON TOF TONR CTU CTD CTUD R_TRIG
F_TRIG SEMA RTC NEG BCD_TO_INT INT_TO_BCD SWAP PEEK POKE
"""
RESERVED = frozenset((_KEYWORDS + _STANDARD_NAMES).split())


def identifier_problem(name: str) -> str | None:
    """Why `name` cannot be an ST identifier, or None when it can."""
    if not name.isascii():
        return "must be ASCII"
    if len(name) > MAX_LENGTH:
        return f"has {len(name)} characters, at most {MAX_LENGTH} are allowed"
    if not _SHAPE.match(name):
        return "must start with a letter and hold only letters, digits and single underscores"
    if name.upper() in RESERVED or re.fullmatch(r"[A-Z]+_TO_[A-Z]+", name.upper()):
        return "is an IEC 61131-3 keyword or standard function/block name"
    return None


def identifier_from_column(column: str) -> str:
    """The block identifier for a CSV column: the column name itself when it is a valid identifier."""
    cleaned = re.sub(r"[^A-Za-z0-9]+", "_", column).strip("_")
    return cleaned


def check_unique(names: list[str]) -> str | None:
    seen: dict[str, str] = {}
    for name in names:
        key = name.upper()
        if key in seen:
            return f"{seen[key]!r} and {name!r} are the same identifier (ST names ignore case)"
        seen[key] = name
    return None
