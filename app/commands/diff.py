"""`thermoplc diff`: what changed between two blocks (thermoplc.verifier.diff); exit 1 when anything did."""
from __future__ import annotations

import argparse

from thermoplc.commands.options import DECIMAL, mapping


def add_parser(sub) -> None:
    p = sub.add_parser("diff", help="what changed between two blocks: constants, interface, statements, behaviour")
    p.add_argument("old", help="the block as it was (ST source or PLCopen XML)")
    p.add_argument("new", help="the block as it is now (ST source or PLCopen XML)")
    p.add_argument("--data", help="replay both blocks on this CSV and report the largest output difference")
    p.add_argument("--decimal", **DECIMAL)
    p.add_argument("--inputs", type=mapping, help="block input to column mapping NAME=COLUMN,...")
    p.add_argument("--time", default="time_s", help="time column (default: %(default)s)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from thermoplc.models.table import read_table
    from thermoplc.verifier.diff import diff_blocks, format_diff
    table = read_table(args.data, args.time, decimal=args.decimal) if args.data else None
    result = diff_blocks(args.old, args.new, table, args.inputs, args.time)
    print(format_diff(result))
    if table is not None and not result.behaviour_equal:
        return 1
    return 0 if result.structurally_equal else 1  # the data never excuses a structural change
