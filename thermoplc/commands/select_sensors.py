"""`thermoplc select-sensors`: group similar temperature sensors and choose one per group
(thermoplc.fitting.selection), on the training rows only."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from thermoplc.base.errors import UserError
from thermoplc.base.fileio import check_output, write_atomic
from thermoplc.commands.options import (FORCE_HELP, OUTPUT, READ_FILE, RESAMPLE, columns, examples, number,
                                        reading_arguments, reading_of, training_part)
from thermoplc.commands.reads import files_read


def add_parser(sub) -> None:
    p = sub.add_parser("select-sensors", help="group similar temperature sensors and choose one per group",
                       **examples("docs/models.md",
                                  "thermoplc select-sensors --data fl_thermal.csv --target ch3_um --train-until 86400 -o sensors.txt",
                                  "thermoplc fit --data fl_thermal.csv --temps @sensors.txt ..."))
    p.add_argument("--data", required=True, type=READ_FILE, help="CSV file (or .npz of columns)")
    p.add_argument("--target", required=True, help="measured displacement column, um")
    p.add_argument("--method", choices=("fcm-grey", "grey-cluster"), default="fcm-grey",
                   help="fcm-grey: paper 001's fuzzy clustering + grey relational grade; "
                        "grey-cluster: paper 002's grey clustering + correlation")
    p.add_argument("--candidates", type=columns,
                   help="temperature columns to choose from (default: the columns named like temperatures - T_..., "
                        "T1, ...temp..., ..._C - whose values all lie in -40..150 degC)")
    p.add_argument("--threshold", type=number(float, 0.0, 1.0, "a degree"), default=0.9,
                   help="grey-cluster: comprehensive degree that joins two sensors (paper 002: %(default)s)")
    p.add_argument("--max-groups", type=number(int, 1, 1000, "groups"), default=5, help="fcm-grey: at most this many groups (default: %(default)s)")
    training_part(p, required=False, default="all rows")
    p.add_argument("--time", default="time_s", help="time column, s (default: %(default)s)")
    p.add_argument("-o", "--output", type=OUTPUT, help="write the chosen sensors for fit --temps @FILE")
    reading_arguments(p)
    p.add_argument("--resample", **{**RESAMPLE, "help": "take raw logger data onto the block's cycle of SECONDS "
                                                         "first (temperatures linear; docs/campaigns.md), as fit "
                                                         "--resample will"})
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from thermoplc.fitting.fit import training_rows
    from thermoplc.fitting.selection import select_sensors
    from thermoplc.recordings.table import read_table, reading_notes
    if args.output:
        check_output(args.output, args.force, inputs=files_read(args))
    table = read_table(args.data, args.time, reading=reading_of(args))
    if args.resample:
        from thermoplc.recordings.resample import Resampling, resample
        table = resample(table, args.time, Resampling(args.resample))
    target = table.column(args.target)
    candidates = _candidates(args, table)
    if args.train_until is None and args.train_rows is None:
        rows = table.rows
    else:
        rows = training_rows(table, args.time, args.train_until, args.train_rows)
    candidates, skipped = _without_leaks(args, table, candidates, target[:rows], rows)
    if rows < 3:
        taken = f" (--resample {args.resample:g} took the data onto {table.rows} calls)" if args.resample else ""
        raise UserError(f"{args.data}: {rows} rows{taken}; grouping sensors needs at least 3 of them")
    try:
        selection = select_sensors({c: table.column(c)[:rows] for c in candidates}, target[:rows],
                                   args.method, args.threshold, args.max_groups)
    except UserError as exc:
        raise UserError(str(exc) if str(exc).startswith(args.data) else f"{args.data}: {exc}") from None
    source = "<stdin>" if args.data == "-" else Path(args.data).name
    for note in reading_notes([table]):  # once the selection stands: a refusal stays one line
        print(note, file=sys.stderr)
    print(f"sensor selection ({selection.method}) for {args.target} on {source}, {rows} rows")
    print(f"  {selection.detail}")
    for column, why in skipped.items():
        print(f"  left out {column}: {why}")
    for k, group in enumerate(selection.groups, start=1):
        members = ", ".join(f"{s} ({selection.scores[s]:.3f})" for s in group)
        print(f"  group {k}: {members}")
    print(f"chosen: {','.join(selection.chosen)}")
    if args.output:
        write_atomic(args.output, f"# thermoplc select-sensors {selection.method} for {args.target}\n"
                     + ",".join(selection.chosen) + "\n")
        print(f"wrote {args.output} (use it as fit --temps @{args.output})")
    return 0


def _candidates(args: argparse.Namespace, table) -> tuple[str, ...]:
    """--candidates, each a temperature; or the columns named and valued like temperatures."""
    from thermoplc.fitting.leaks import TEMPERATURE_RULE, refuse_non_temperatures, temperature_columns
    if args.candidates:
        refuse_non_temperatures(table, args.candidates, "--candidates")
        return args.candidates
    found = temperature_columns(table.columns, (args.time, args.target))
    if not found:
        raise UserError(f"{args.data}: no temperature columns recognised ({TEMPERATURE_RULE.format(low=-40, high=150)}); "
                        f"name them with --candidates")
    return found


def _without_leaks(args: argparse.Namespace, table, candidates: tuple[str, ...], target, rows: int) -> tuple[tuple, dict]:
    """A column that is the target in disguise: an error in the user's list, left out (with the reason)
    of the recognised ones. Returns the candidates kept and the reason for each left out."""
    from thermoplc.fitting.leaks import leak_reason, refuse_leaks
    if args.candidates:
        refuse_leaks({c: table.column(c)[:rows] for c in candidates}, args.target, target, args.data, "--candidates")
        return candidates, {}
    skipped = {c: why for c in candidates if (why := leak_reason(c, table.column(c)[:rows], args.target, target))}
    kept = tuple(c for c in candidates if c not in skipped)
    if not kept:
        raise UserError(f"{args.data}: every temperature column is the target in disguise: "
                        + "; ".join(f"{c} {why}" for c, why in skipped.items()))
    return kept, skipped
