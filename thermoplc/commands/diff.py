"""`thermoplc diff`: what changed between two blocks (thermoplc.verifier.replays.diff); exit 1 when anything did."""
from __future__ import annotations

import argparse
import sys

from thermoplc.commands import json_output
from thermoplc.base.errors import UserError
from thermoplc.commands.options import (EVERY_HELP, READ_FILE, every, examples, mapping, named, number,
                                        reading_arguments, reading_of)
from thermoplc.commands.reads import files_read


def add_parser(sub) -> None:
    p = sub.add_parser("diff", help="what changed between two blocks: constants, interface, statements, behaviour",
                       **examples("docs/reliability.md",
                                  "thermoplc diff old/ThermalComp.scl ThermalComp.scl",
                                  "thermoplc diff a.scl b.scl --data recording.csv",
                                  "thermoplc diff a.scl b.scl --data run.csv --probe-target E_z_um --held-target"))
    p.add_argument("old", type=READ_FILE, help="the block as it was (ST source or PLCopen XML)")
    p.add_argument("new", type=READ_FILE, help="the block as it is now (ST source or PLCopen XML)")
    p.add_argument("--data", type=READ_FILE, help="replay both blocks on this CSV and report the largest output difference")
    reading_arguments(p)
    p.add_argument("--inputs", type=mapping, help="block input to column mapping NAME=COLUMN,...")
    p.add_argument("--probe-target", metavar="COLUMN", type=named("--probe-target"),
                   help="fused blocks (fit --probe): replay the probings from this target column (its measured rows, "
                        "or with --probe-every a probing every N calls of a target measured at every call)")
    p.add_argument("--probe-every", type=every, metavar="WHEN", help=f"with --probe-target: a probing every {EVERY_HELP}")
    p.add_argument("--held-target", action="store_true",
                   help="with --probe-target: the target holds its last probing between probings")
    p.add_argument("--time", default="time_s", help="time column (default: %(default)s)")
    json_output.add_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from thermoplc.recordings.table import read_table, reading_notes
    from thermoplc.verifier.replays.diff import diff_blocks, format_diff
    from thermoplc.verifier.replays.documents import diff_document
    json_output.check(args, files_read(args))
    if (args.probe_every or args.held_target) and not args.probe_target:
        raise UserError("--probe-every and --held-target say how --probe-target holds the probings; "
                        "give --probe-target")
    if args.probe_target and not args.data:
        raise UserError("--probe-target replays probings on --data; give --data")
    table = (read_table(args.data, args.time, reading=reading_of(args), sparse=(args.probe_target,) if args.probe_target
                        else ()) if args.data else None)
    if args.probe_target:
        from thermoplc.verifier.replays.probings import with_probings
        from thermoplc.fitting.fit import sample_period
        every = args.probe_every.calls_at(sample_period(table, args.time)) if args.probe_every else None
        table = with_probings(table, args.probe_target, every, args.held_target)
    result = diff_blocks(args.old, args.new, table, args.inputs, args.time)
    for note in reading_notes([table] if table is not None else []):  # once the diff stands: a refusal stays one line
        print(note, file=sys.stderr)
    json_output.emit(args, format_diff(result), diff_document(result, table is not None) if args.json else None)
    if table is not None and not result.behaviour_equal:
        return 1
    return 0 if result.structurally_equal else 1  # the data never excuses a structural change
