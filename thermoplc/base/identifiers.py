"""Identifier rules of numeric contract rule 6, applied to every name that reaches emitted ST: one neutral module
that the models (checking a model file) and the generator (checking a block) both read."""
from __future__ import annotations

import hashlib
import re

from thermoplc.base.errors import UserError

MAX_LENGTH = 24  # STEP 7 classic symbol limit
_SHAPE = re.compile(r"[A-Za-z](?:_?[A-Za-z0-9])*\Z")

# IEC 61131-3 3rd edition keywords and elementary types
_IEC_KEYWORDS = """
ABSTRACT ACTION AND ANY ANY_BIT ANY_CHAR ANY_CHARS ANY_DATE ANY_DERIVED ANY_DURATION ANY_ELEMENTARY ANY_INT
ANY_MAGNITUDE ANY_NUM ANY_REAL ANY_SIGNED ANY_STRING ANY_UNSIGNED ARRAY AT BOOL BY BYTE CASE CHAR CLASS
CONFIGURATION CONSTANT CONTINUE DATE DATE_AND_TIME DINT DO DT DWORD ELSE ELSIF EN ENO END_ACTION END_CASE
END_CLASS END_CONFIGURATION END_FOR END_FUNCTION END_FUNCTION_BLOCK END_IF END_INTERFACE END_METHOD
END_NAMESPACE END_PROGRAM END_REPEAT END_RESOURCE END_STEP END_STRUCT END_TRANSITION END_TYPE END_VAR
END_WHILE EXIT EXTENDS F_EDGE FALSE FINAL FOR FROM FUNCTION FUNCTION_BLOCK IF IMPLEMENTS INITIAL_STEP INT
INTERFACE INTERNAL INTERVAL LDATE LDATE_AND_TIME LDT LINT LREAL LTIME LTIME_OF_DAY LTOD LWORD METHOD MOD
NAMESPACE NON_RETAIN NOT NULL OF ON OR OVERLAP OVERRIDE PRIORITY PRIVATE PROGRAM PROTECTED PUBLIC R_EDGE
READ_ONLY READ_WRITE REAL REF REF_TO REPEAT RESOURCE RETAIN RETURN SINGLE SINT STEP STRING STRUCT SUPER TASK
THEN THIS TIME TIME_OF_DAY TO TOD TRANSITION TRUE TYPE UDINT UINT ULINT UNTIL USING USINT VAR VAR_ACCESS
VAR_CONFIG VAR_EXTERNAL VAR_GLOBAL VAR_IN_OUT VAR_INPUT VAR_OUTPUT VAR_TEMP WCHAR WHILE WITH WORD WSTRING XOR
"""
# Siemens SCL (TIA Portal and classic STEP 7): block keywords, header attributes, parameter types
_SCL_KEYWORDS = """
AUTHOR BEGIN BLOCK_DB BLOCK_FB BLOCK_FC BLOCK_SDB CODE_VERSION1 CONST COUNTER DATA_BLOCK DB_ANY DTL
END_CONST END_DATA_BLOCK END_LABEL END_ORGANIZATION_BLOCK END_REGION FAMILY GOTO KNOW_HOW_PROTECT LABEL
NAME OK ORGANIZATION_BLOCK POINTER REGION S5TIME TIMER TITLE UDT UNLINKED VARIANT VERSION VOID
"""
# CODESYS extensions (object orientation, pointers, unions, instruction-list operators)
_CODESYS_KEYWORDS = """
ADR AND_THEN BITADR BIT CAL END_PROPERTY END_UNION INDEXOF ISVALIDREF JMP PERSISTENT PROPERTY REFERENCE RET SIZEOF
OR_ELSE UNION VAR_INST VAR_STAT XSIZEOF
"""
_STANDARD_NAMES = """
ABS SQRT LN LOG EXP EXPT SIN COS TAN ASIN ACOS ATAN ATAN2 ADD SUB MUL DIV MOVE SEL MAX MIN LIMIT
MUX GT GE EQ LE LT NE SHL SHR ROL ROR LEN LEFT RIGHT MID CONCAT INSERT DELETE REPLACE FIND TRUNC
ROUND CEIL FLOOR FRAC NORM_X SCALE_X SCALE UNSCALE SR RS TP TON TOF TONR CTU CTD CTUD R_TRIG
F_TRIG SEMA RTC NEG BCD_TO_INT INT_TO_BCD SWAP PEEK POKE
"""
# absolute addresses in classic SCL (M10, DBW4, PIW256, T5 ...) read as memory, not as a name
_ADDRESS = re.compile(r"(?:[IQMETCZLXA]|DB|DI|P[IQEA]|[IQMELA][BWD]|DB[XBWD]|DI[XBWD]|P[IQEA][BWD]"
                      r"|FB|FC|OB|SFB|SFC|UDT|VAT|SDB)\d+\Z")  # ... and block numbers (FC1, OB35, UDT5)
RESERVED = frozenset((_IEC_KEYWORDS + _SCL_KEYWORDS + _CODESYS_KEYWORDS + _STANDARD_NAMES).split())


def identifier_problem(name: str) -> str | None:
    """Why `name` cannot be an ST identifier, or None when it can."""
    if not name.isascii():
        return "must be ASCII"
    if len(name) > MAX_LENGTH:
        return f"has {len(name)} characters, at most {MAX_LENGTH} are allowed (the STEP 7 symbol limit, kept in every dialect)"
    if not _SHAPE.match(name):
        return "must start with a letter and hold only letters, digits and single underscores"
    if name.upper() in RESERVED or re.fullmatch(r"[A-Z]+_TO_[A-Z]+", name.upper()):
        return "is a reserved word (IEC 61131-3, Siemens SCL or CODESYS) or a standard function/block name"
    if _ADDRESS.match(name.upper()):
        return "reads as an absolute address (like M10 or DBW4) in Siemens SCL"
    return None


_ATTRIBUTE = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,7}\Z")  # STEP 7 AUTHOR, FAMILY, NAME: at most 8 characters


def header_attribute_problem(text: str) -> str | None:
    """Why `text` cannot be a STEP 7 header attribute (AUTHOR, FAMILY, NAME), or None: at most 8 characters
    and an identifier (AUTHOR : BEGIN would read as the start of the code to an SCL compiler)."""
    if not _ATTRIBUTE.match(text):
        return (f"expected a letter, then letters, digits or '_', 8 characters at most (STEP 7 header attribute), "
                f"found {text!r}")
    problem = identifier_problem(text)
    return f"{text!r} {problem}" if problem else None


_UNIT_LETTERS = str.maketrans({"µ": "u", "μ": "u", "℃": "C", "Ω": "Ohm"})  # micro sign and Greek mu


def identifier_from_column(column: str) -> str:
    """The block identifier for a CSV column: the column name itself when it is a valid identifier; a unit keeps
    its meaning (`E_z [µm]` is `E_z_um`, not `E_z_m`, which reads as metres)."""
    spelled = column.translate(_UNIT_LETTERS)
    cleaned = re.sub(r"[^A-Za-z0-9]+", "_", spelled).strip("_")
    return cleaned


def _shown(text: str) -> str:
    return repr(text) if len(text) <= 40 else repr(text[:30]) + f"... ({len(text)} characters)"


def block_identifier(column: str, what: str) -> str:
    """The block name for a recorded column: the column itself when it is a valid identifier, else
    one derived from it (`T4`, a timer address in SCL, becomes `T4_in`; a target `TIME` becomes
    `TIME_out`). The model file keeps both, the block header states the column of a renamed input,
    so a common export (T1..T16) needs no renaming by hand. A UserError when nothing safe derives."""
    name = identifier_from_column(column)
    if identifier_problem(name) is None:
        return name
    end = "out" if what == "target" else "in"
    stem = name if name[:1].isalpha() else f"{end}_{name}" if name else f"{end}_{identifier_from_column(what)}"
    derived = stem if identifier_problem(stem) is None else f"{stem}_{end}"
    if len(derived) > MAX_LENGTH:  # cut, with a digest of the whole column so two long columns stay apart
        digest = hashlib.sha1(column.encode("utf-8", "surrogatepass")).hexdigest()[:6]
        derived = f"{derived[:MAX_LENGTH - 7].rstrip('_')}_{digest}"
    problem = identifier_problem(derived)
    if problem:
        raise UserError(f"{what} column {_shown(column)} gives block name {_shown(derived)}, which {problem}; "
                        "rename the column")
    return derived


def renaming_note(column: str, name: str) -> str | None:
    """Why a column's block name differs from the column, for the fit's summary; None when it does not."""
    if name == column:
        return None
    cleaned = identifier_from_column(column)
    why = identifier_problem(cleaned) if cleaned else "has no letter or digit"
    return f"column {_shown(column)} is block name {name}" + (f" ({_shown(cleaned)} {why})" if why else "")


def check_unique(names: list[str]) -> str | None:
    seen: dict[str, str] = {}
    for name in names:
        key = name.upper()
        if key in seen:
            return f"{seen[key]!r} and {name!r} are the same identifier (ST names ignore case)"
        seen[key] = name
    return None
