"""`--json FILE` of verify, diff and fit: the result as a JSON document beside the text, for CI.

'-' puts the document on standard output and the text on standard error, so a pipeline reads one
stream. The file is checked like every output before the work starts (never an input, --force to
replace it) and written atomically after it."""
from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.base.fileio import check_outputs, write_atomic
from thermoplc.commands.options import FORCE_HELP
from thermoplc.commands.reads import Writes

JSON_HELP = ("also write the result as a JSON document to FILE ('-': standard output, the text then goes to "
             "standard error); its JSON Schema is installed with thermoplc (thermoplc/schemas/<command>_v1.json), "
             "the format described in the repository's docs/json.md")


def _file_name(text: str) -> str:
    if not text:
        raise argparse.ArgumentTypeError("expected a file name or '-', found an empty name")
    return text


def add_arguments(p, force: bool = True) -> None:
    p.add_argument("--json", metavar="FILE", type=Writes(_file_name), help=JSON_HELP)
    if force:
        p.add_argument("--force", action="store_true", help=FORCE_HELP)


def check(args, inputs, output: str | None = None) -> None:
    """Refuse a --json file the output rule does not allow (base/fileio.check_outputs: an existing file
    without --force, an input, the command's -o) before any work."""
    check_outputs({"-o": output, "--json": file(args)}, args.force, inputs=[i for i in inputs if i])


def file(args) -> str | None:
    """The --json file, None when not given or on standard output."""
    return None if args.json in (None, "-") else args.json


def encoded(document: dict) -> str:
    """The document as the --json file holds it."""
    return json.dumps(_finite(document), indent=2, allow_nan=False) + "\n"


def emit(args, text: str, document: dict | None, written: bool = False) -> None:
    """The text on standard output, or on standard error when the document takes standard output; the document
    written to its file unless the caller `written` it with its other outputs."""
    to_stdout = args.json == "-"
    print(text, file=sys.stderr if to_stdout else sys.stdout)
    if not args.json or document is None:
        return
    if to_stdout:
        sys.stdout.write(encoded(document))
    elif not written:
        write_atomic(args.json, encoded(document))


def _finite(value):
    """Plain JSON values: numpy scalars as Python numbers, NaN and infinities as text ("nan", "inf",
    "-inf"), since JSON has no number for them."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, dict):
        return {key: _finite(v) for key, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value
