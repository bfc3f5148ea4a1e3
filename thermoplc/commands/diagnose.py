"""`thermoplc diagnose`: the physical effect the lumped-mass simulation misses (thermoplc.diagnosis)."""
from __future__ import annotations

import argparse
from pathlib import Path

from thermoplc.base.errors import UserError
from thermoplc.base.fileio import check_outputs
from thermoplc.commands.options import (FORCE_HELP, MODEL_FILE, OUTPUT, RESAMPLE, RUNS, campaign_arguments,
                                        columns, examples, named, reading_arguments, reading_of,
                                        scheduler_address, training_part)
from thermoplc.commands.reads import Writes, files_read
from thermoplc.commands.terminal import end_progress, progress


def add_parser(sub) -> None:
    p = sub.add_parser("diagnose", help="find the physical effect the lumped-mass simulation misses",
                       **examples("docs/diagnosis.md",
                                  "thermoplc diagnose --data fl_thermal.csv --temps t5_C,t4_C --speed spindle_rpm \\",
                                  "    --ambient t6_C --target ch3_um --report diag -o diagnosed.json",
                                  "thermoplc diagnose --data injected.csv ... --baseline diagnosed.json -o injected.json"))
    campaign_arguments(p, "each started as a fresh block, the evidence pooled over them", "")
    p.add_argument("--train-runs", type=RUNS, metavar="N",
                   help="a campaign: its first N runs train, the others are held out (default: 60%% of the runs, "
                        "the first ones, or, when the runs' hall air differs by 2 K or more, the coldest, the "
                        "warmest and runs spread between them)")
    p.add_argument("--temps", type=columns, required=True, help="temperature columns, comma-separated")
    p.add_argument("--speed", required=True, help="spindle speed column, rpm")
    p.add_argument("--ambient", required=True, help="ambient temperature column, degC")
    p.add_argument("--target", required=True,
                   help="measured displacement column, um; a probed target may be empty between probings (judged at "
                        "its probings, its noise estimated from them)")
    p.add_argument("--held-target", action="store_true",
                   help="the target holds its last probing between probings: only the first row and the rows where "
                        "it changes are measurements")
    p.add_argument("--feed", help="feed-axis rate column, mm/min (enables the feed_axis_heat candidate)")
    p.add_argument("--baseline", type=MODEL_FILE,
                   help="a lumped model file (`fit --model lumped` or diagnose wrote it) to start from "
                        "instead of identifying the baseline")
    p.add_argument("--no-structure-lag", action="store_true",
                   help="baseline displacement from the filtered temperatures alone (paper 000 eq. 10), without "
                        "the structure that lags them")
    training_part(p, required=False, default="the first 60%% of the rows")
    p.add_argument("--time", default="time_s", help="time column, s (default: %(default)s)")
    p.add_argument("--name", default="ThermalComp", help="function block name of the augmented model")
    reading_arguments(p)
    p.add_argument("--resample", **RESAMPLE)
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("--scheduler", metavar="ADDRESS", type=scheduler_address,
                   help="try each round's candidate effects as tasks of the Dask distributed cluster whose scheduler "
                        "is at ADDRESS (tcp://HOST:PORT; the fleet extra); every worker reads the runs by the paths "
                        "given. The same findings, bit for bit")
    p.add_argument("--json", type=OUTPUT, help="write the findings here (findings.json)")
    p.add_argument("--report", metavar="FOLDER", type=Writes(named("a folder for the report")),
                   help="write an HTML report with plots into this folder")
    p.add_argument("-o", "--output", default="diagnosed_model.json", type=OUTPUT,
                   help="augmented model file (default: %(default)s)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from thermoplc.diagnosis.command import DiagnoseRequest, run as diagnose
    from thermoplc.diagnosis.findings import text
    from thermoplc.recordings.campaign import run_list
    request = DiagnoseRequest(tuple(args.data) if args.data else None, args.temps, args.speed, args.ambient,
                              args.target, args.feed, args.baseline, args.train_until, args.train_rows, args.time,
                              args.name, reading_of(args), not args.no_structure_lag, args.runs, args.train_runs,
                              args.resample, args.held_target)
    if args.baseline and args.no_structure_lag:
        raise UserError("--no-structure-lag shapes a fitted baseline; with --baseline the model file decides")
    runs = run_list(args.data, args.runs)
    from thermoplc.diagnosis.report import is_report_file, report_files
    check_outputs({"-o": args.output, "--json": args.json}, args.force, files_read(args), args.report,
                  report_files(len(args.temps) + 1, len(runs.paths)), is_report_file)
    doc = diagnose(request, args.output, args.json, args.report, progress(), args.scheduler)
    end_progress()
    print(text(doc))
    print(f"wrote {args.output}" + (f", {args.json}" if args.json else "")
          + (f", {Path(args.report) / 'index.html'}" if args.report else ""))
    return 0
