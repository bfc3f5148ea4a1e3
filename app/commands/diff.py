"""`thermoplc diff`: what changed between two blocks (thermoplc.verifier.diff); exit 1 when anything did."""
from __future__ import annotations

import argparse

from thermoplc.commands import json_output
from thermoplc.commands.options import DECIMAL, mapping


def add_parser(sub) -> None:
    p = sub.add_parser("diff", help="what changed between two blocks: constants, interface, statements, behaviour")
    p.add_argument("old", help="the block as it was (ST source or PLCopen XML)")
    p.add_argument("new", help="the block as it is now (ST source or PLCopen XML)")
    p.add_argument("--data", help="replay both blocks on this CSV and report the largest output difference")
    p.add_argument("--decimal", **DECIMAL)
    p.add_argument("--inputs", type=mapping, help="block input to column mapping NAME=COLUMN,...")
    p.add_argument("--time", default="time_s", help="time column (default: %(default)s)")
    json_output.add_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from thermoplc.models.table import read_table
    from thermoplc.verifier.diff import diff_blocks, format_diff
    from thermoplc.verifier.documents import diff_document
    json_output.check(args, [args.old, args.new, args.data])
    table = read_table(args.data, args.time, decimal=args.decimal) if args.data else None
    result = diff_blocks(args.old, args.new, table, args.inputs, args.time)
    json_output.emit(args, format_diff(result), diff_document(result, table is not None) if args.json else None)
    if table is not None and not result.behaviour_equal:
        return 1
    return 0 if result.structurally_equal else 1  # the data never excuses a structural change
