"""`thermoplc testbench`: a test bench for the PLC itself (thermoplc.pipeline.testbench): the block called
once per recorded row, every output compared with the float32 reference, the verdict in the PLC's own
variables; run here first, in thermoplc's interpreter."""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from thermoplc.base.errors import UserError
from thermoplc.commands.options import (EVERY_HELP, FORCE_HELP, READ_FILE, RECORDING, RESAMPLE, every,
                                        examples, mapping, named, number, reading_arguments, reading_of)
from thermoplc.commands.reads import Writes, files_read
from thermoplc.commands.terminal import progress


def add_parser(sub) -> None:
    p = sub.add_parser("testbench", help="write a test bench that proves the block on the PLC itself",
                       **examples("docs/commissioning.md",
                                  "thermoplc testbench ThermalComp.scl --model model.json --data twin.csv -o bench",
                                  "thermoplc testbench ThermalComp.st --model model.json --data twin.csv -o bench "
                                  "--calls 2000 --from 5001"))
    p.add_argument("block", type=READ_FILE, help="the block generate wrote (its dialect is the bench's: tia, step7, "
                                                 "iec, or PLCopen XML)")
    p.add_argument("--model", required=True, type=READ_FILE, help="the model file the block was generated from")
    p.add_argument("--data", required=True, type=RECORDING, help="the recording whose rows the bench replays")
    p.add_argument("-o", "--output", required=True, metavar="DIR", type=Writes(named("a folder")),
                   help="folder for the bench's source (made when missing)")
    p.add_argument("--calls", type=number(int, 1, 32767, "calls"),
                   help="rows replayed (default: as many as fit one download of the smallest CPU of the dialect's "
                        "family, 256 KiB of data, at most the rows there are)")
    p.add_argument("--from", dest="first", type=number(int, 1, 10 ** 9, "rows"), default=1, metavar="ROW",
                   help="the data row of the first call, counted from 1; the block is Reset there (a new "
                        "instance's state) (default: %(default)s)")
    p.add_argument("--rows-per-cycle", type=number(int, 1, 1000, "rows"), default=50,
                   help="calls of the block per PLC cycle, so that the cycle time stays short (default: %(default)s)")
    p.add_argument("--tolerance-um", type=number(float, 0.0, 1e6, "micrometres"), default=0.0,
                   help="a REAL output passes within this of the reference (the contraction bound verify states, for "
                        "a target that fuses multiply-adds); 0: bit-exact (default: %(default)s)")
    reading_arguments(p)
    p.add_argument("--resample", **RESAMPLE)
    p.add_argument("--inputs", type=mapping, help="block input to column mapping NAME=COLUMN,...")
    p.add_argument("--probe-every", type=every, metavar="WHEN",
                   help=f"a fused block on a target measured at every call: a probing every {EVERY_HELP}")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from thermoplc.base.fileio import check_output, write_atomic
    from thermoplc.models.modelfile import load_model
    from thermoplc.pipeline import testbench
    from thermoplc.verifier.recording import read_recording
    read = files_read(args)
    folder = Path(args.output)
    if folder.exists() and not folder.is_dir():
        raise UserError(f"-o {args.output}: not a folder; the bench is written into a folder")
    model = load_model(args.model)
    table = read_recording(args.data, model, progress(), reading_of(args, model), args.resample, args.inputs,
                           args.model)
    try:
        bench = testbench(args.block, model, args.model, table, args.first - 1, args.calls, args.rows_per_cycle,
                          args.tolerance_um, args.inputs, args.probe_every)
    except UserError as exc:
        raise UserError(str(exc).replace("model file:", f"{args.model}:", 1)) from None
    path = folder / (bench.name + (".xml" if bench.plcopen else ".st" if bench.dialect == "iec" else ".scl"))
    check_output(path, args.force, inputs=read)
    counters = bench.counters
    for line in summary(bench, args.block, table.path, table.rows, args.calls is None):
        print(line)
    if counters.mismatches or not counters.done:
        print(f"thermoplc: {args.block}: fails its own test bench in thermoplc's interpreter; nothing written: "
              f"verify names the first cycle where it differs from the reference", file=sys.stderr)
        return 1
    os.makedirs(folder, exist_ok=True)
    write_atomic(path, bench.text)
    print(f"wrote {path}: import it after {Path(args.block).name} (docs/commissioning.md, 'The test bench on the PLC')")
    return 0


def _counters(c) -> str:
    said = f"Done = {c.done}, Calls = {c.calls}, Mismatches = {c.mismatches}"
    if c.mismatches:
        said += (f", FirstMismatchCall = {c.first_mismatch_call}, FirstMismatchOutput = {c.first_mismatch_output} "
                 f"(expected {c.first_expected!r}, block {c.first_actual!r})")
    return said


def summary(bench, block: str, data: str, rows: int, chosen: bool) -> list[str]:
    """What the bench holds and how it ran here, as the console prints it; `chosen`: the calls by default."""
    plan, c = bench.plan, bench.counters
    form = "PLCopen XML (iec)" if bench.plcopen else bench.dialect
    where = (f"{bench.data_blocks} data block{'s' if bench.data_blocks > 1 else ''}" if bench.dialect != "iec" else
             f"constant arrays in {bench.data_blocks} part{'s' if bench.data_blocks > 1 else ''}")
    compared = "exactly" if not plan.tolerance else f"within {plan.tolerance:g} (REAL; BOOL and INT exactly)"
    verdict = "exact" if not plan.tolerance or not any(c.max_diff) else "within the stated bound"
    return [f"test bench {bench.name} ({form}) for {Path(block).name}: {plan.calls:,} calls, rows {bench.first + 1:,} "
            f"to {bench.first + plan.calls:,} of {Path(data).name}'s {rows:,}"
            + (" (the most that fit 256 KiB of data, one download; --calls and --from choose others)"
               if chosen and plan.calls < rows - bench.first else ""),
            f"  the block Reset at call 1, then driven as recorded; {len(plan.outputs)} outputs compared {compared}",
            f"  data: {where} of at most {bench.largest_bytes:,} bytes each (limit 65,536), "
            f"{plan.calls * plan.row_bytes:,} bytes of values in all",
            f"  {plan.rows_per_cycle} calls of the block per PLC cycle: Done after {c.cycles} cycles",
            f"  run here (thermoplc's interpreter): {_counters(c)}: {verdict}"]
