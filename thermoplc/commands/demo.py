"""`thermoplc demo`: the whole pipeline on the bundled FL_THERMAL recording (thermoplc.demo)."""
from __future__ import annotations

import argparse
from pathlib import Path

from thermoplc.commands.options import FORCE_HELP, OUTPUT, examples


def add_parser(sub) -> None:
    p = sub.add_parser("demo", help="whole pipeline on the bundled FL_THERMAL recording",
                       **examples("README.md and docs/models.md#the-demo-fl_thermal-ch3",
                                  "thermoplc demo",
                                  "thermoplc demo --out demo_out"))
    p.add_argument("--out", default="thermoplc-demo", type=OUTPUT, help="output folder (default: %(default)s)")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from thermoplc.demo import run_demo
    return run_demo(Path(args.out), args.force)
