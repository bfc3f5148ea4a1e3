"""`thermoplc testbench`: a test bench for the PLC itself (thermoplc.pipeline.testbench): the block called
once per recorded row, every output compared with the float32 reference, the verdict in the PLC's own
variables; run here first, in thermoplc's interpreter."""
from __future__ import annotations

import argparse
import os
import sys
from collections import Counter
from pathlib import Path

from thermoplc.base.errors import UserError
from thermoplc.commands.options import (EVERY_HELP, FORCE_HELP, READ_FILE, RESAMPLE, every,
                                        examples, mapping, named, number, reading_arguments, reading_of)
from thermoplc.commands.reads import Reads, Writes, files_read
from thermoplc.commands.terminal import progress
from thermoplc.recordings.formats import described


def _rows_per_cycle(dialects) -> str:
    """The dialects' calls per cycle in a bench, as the help says them: '10 for step7, 50 elsewhere'."""
    counts = Counter(d.rows_per_cycle for d in dialects)
    usual = counts.most_common(1)[0][0]
    others = [f"{d.rows_per_cycle} for {d.name}" for d in dialects if d.rows_per_cycle != usual]
    return ", ".join([*others, f"{usual} elsewhere"]) if others else str(usual)


def add_parser(sub) -> None:
    p = sub.add_parser("testbench", help="write a test bench that proves the block on the PLC itself",
                       **examples("docs/commissioning.md",
                                  "thermoplc testbench ThermalComp.scl --model model.json --data twin.csv -o bench",
                                  "thermoplc testbench ThermalComp.st --model model.json --data twin.csv -o bench "
                                  "--calls 2000 --from 5001"))
    from thermoplc.generator.dialects import registry  # the dialects' records: names, budgets, calls per cycle
    dialects = registry().values()
    p.add_argument("block", type=READ_FILE, help="the block generate wrote (its dialect is the bench's: "
                                                 f"{', '.join(d.name for d in dialects)}, or PLCopen XML)")
    p.add_argument("--model", required=True, type=READ_FILE, help="the model file the block was generated from")
    p.add_argument("--data", required=True, type=Reads("file", named(f"a recording ({described()})")),
                   help="the recording whose rows the bench replays")
    p.add_argument("-o", "--output", required=True, metavar="DIR", type=Writes(named("a folder")),
                   help="folder for the bench's source (made when missing)")
    p.add_argument("--calls", type=number(int, 1, 32767, "calls"),
                   help="rows replayed (default: as many as fit the dialect's data budget, at most the rows there "
                        f"are: {'; '.join(f'{d.name}: {d.bench.why}' for d in dialects)})")
    p.add_argument("--from", dest="first", type=number(int, 1, 10 ** 9, "rows"), default=1, metavar="ROW",
                   help="the data row of the first call, counted from 1; the block is Reset there (a new "
                        "instance's state) (default: %(default)s)")
    p.add_argument("--rows-per-cycle", type=number(int, 1, 1000, "rows"),
                   help="calls of the block per PLC cycle, so that the cycle time stays short (default: "
                        f"{_rows_per_cycle(dialects)})")
    p.add_argument("--tolerance-um", type=number(float, 0.0, 1000.0, "micrometres"), default=0.0,
                   help="a REAL output passes within this of the reference (urad for an angle, a thousandth of it for a "
                        "K0 output in mm): for a target that fuses multiply-adds, a few times the figure verify's "
                        "'contraction:' line states; 0: bit-exact (default: %(default)s)")
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
    from thermoplc.verifier.replays.recording import read_recording
    from thermoplc.verifier.replays.replay import other_model
    read = files_read(args)
    if 0 < args.tolerance_um < 1e-30:
        raise UserError(f"--tolerance-um {args.tolerance_um:g}: expected 0 (bit-exact) or at least 1e-30 (a K0 output's "
                        f"thousandth of it must be a normal REAL)")
    path = _bench_path(args.block, args.output)
    check_output(path, args.force, inputs=read)  # before any work
    model = load_model(args.model)
    table = read_recording(args.data, model, progress(), reading_of(args, model), args.resample, args.inputs,
                           args.model)
    try:
        bench = testbench(args.block, model, args.model, table, args.first - 1, args.calls, args.rows_per_cycle,
                          args.tolerance_um, args.inputs, args.probe_every)
    except UserError as exc:
        raise UserError(str(exc).replace("model file:", f"{args.model}:", 1)) from None
    for line in summary(bench, args.block, table.path, table.rows, args.calls is None):
        print(line)
    c = bench.counters
    if c.mismatches or not c.done or any(c.max_diff):  # here the block must be exact, whatever the tolerance
        origin = other_model(args.block, model, args.model)
        print(f"thermoplc: error: {args.block}: differs from the reference in its own test bench in thermoplc's "
              f"interpreter; nothing written{f' ({origin})' if origin else ''}: verify names the first cycle where "
              f"it differs", file=sys.stderr)
        return 1
    os.makedirs(path.parent, exist_ok=True)
    write_atomic(path, bench.text)
    print(f"wrote {path}: import it after {Path(args.block).name} (docs/commissioning.md, 'The test bench on the PLC')")
    return 0


def _bench_path(block: str, output: str) -> Path:
    """Where the bench goes: the folder -o names (made when missing: every part of it that exists a folder)."""
    from thermoplc.generator.dialects import registry
    from thermoplc.generator.testbench import bench_names
    from thermoplc.pipeline import block_dialect
    from thermoplc.verifier.reading.block_file import parse_file
    if output in ("", "-"):
        raise UserError(f"-o {output!r}: expected a folder for the test bench")
    folder = Path(output)
    for part in (folder, *folder.parents):
        if part.exists():
            if not part.is_dir():
                raise UserError(f"-o {output}: {part} is not a folder; the bench is written into a folder")
            break
    dialect, plcopen = block_dialect(block)
    name = bench_names(parse_file(block).name)[0]
    return folder / (name + (".xml" if plcopen else registry()[dialect].suffix))


def _counters(c) -> str:
    said = f"Done = {c.done}, Calls = {c.calls}, Mismatches = {c.mismatches}"
    if c.mismatches:
        said += (f", FirstMismatchCall = {c.first_mismatch_call}, FirstMismatchOutput = {c.first_mismatch_output} "
                 f"(expected {c.first_expected!r}, block {c.first_actual!r})")
    return said


def summary(bench, block: str, data: str, rows: int, chosen: bool) -> list[str]:
    """What the bench holds and how it ran here, as the console prints it; `chosen`: the calls by default. Here
    the block must be exact whatever the tolerance: the tolerance is the PLC's."""
    from thermoplc.generator.dialects import registry
    from thermoplc.generator.testbench import TARGETS
    plan, c = bench.plan, bench.counters
    form = "PLCopen XML (iec)" if bench.plcopen else bench.dialect
    where = (f"{bench.data_blocks} data block{'s' if bench.data_blocks > 1 else ''}"
             if registry()[bench.dialect].bench_spelling.data_blocks else
             f"constant arrays in {bench.data_blocks} part{'s' if bench.data_blocks > 1 else ''}")
    tolerances = ", ".join(f"{p.name} {p.tolerance:g}" for p in plan.outputs if p.tolerance)
    compared = f"within {tolerances} (the others exactly)" if tolerances else "exactly"
    verdict = ("exact" if c.done and not c.mismatches and not any(c.max_diff) else
               f"NOT exact: {c.mismatches} call{'s' if c.mismatches != 1 else ''} beyond the tolerance, outputs off by up "
               f"to {', '.join(f'{x:g}' for x in c.max_diff)}")
    return [f"test bench {bench.name} ({form}) for {Path(block).name}: {plan.calls:,} calls, rows {bench.first + 1:,} "
            f"to {bench.first + plan.calls:,} of {Path(data).name}'s {rows:,}"
            + (f" (the most that fit {TARGETS[bench.dialect].download_bytes // 1024} KiB of data: "
               f"{TARGETS[bench.dialect].why}; --calls and --from choose others)"
               if chosen and plan.calls < rows - bench.first else ""),
            f"  the block Reset at call 1, then driven as recorded; {len(plan.outputs)} outputs compared {compared}",
            f"  data: {where} of at most {bench.largest_bytes:,} bytes each (limit 65,536), "
            f"{plan.calls * plan.row_bytes:,} bytes of values in all",
            f"  {plan.rows_per_cycle} calls of the block per PLC cycle: Done after {c.cycles} cycles",
            f"  run here (thermoplc's interpreter): {_counters(c)}: {verdict}"]
