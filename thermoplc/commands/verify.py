"""`thermoplc verify`: replay data through a block and compare every output bit for bit
(thermoplc.verifier): exit 0 bit-exact, 1 not (or unsafe), 2 bad input."""
from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

from thermoplc.base.errors import UserError
from thermoplc.commands import json_output
from thermoplc.commands.options import (EVERY_HELP, READ_FILE, RECORDING, RESAMPLE, RUNS_TABLE, columns, every,
                                        examples, given_reading, mapping, named, number, reading_arguments,
                                        reading_of, scheduler_address)
from thermoplc.commands.reads import Reads, Writes, files_read
from thermoplc.commands.terminal import progress
from thermoplc.recordings.formats import described


def add_parser(sub) -> None:
    p = sub.add_parser("verify", help="replay data through a block and compare every output bit for bit",
                       **examples("docs/reliability.md and docs/commissioning.md",
                                  "thermoplc verify ThermalComp.scl --model model.json --data twin.csv",
                                  "thermoplc verify ThermalComp.scl --model model.json --data twin.csv --faults",
                                  "thermoplc verify ThermalComp.scl --model model.json --data twin.csv --outputs outputs.csv",
                                  "thermoplc verify ThermalComp.scl --data trace.csv --expect E_z_um=plc_E"))
    data = p.add_argument_group("data")
    against = p.add_argument_group("compared with (a model's reference, or outputs a PLC recorded)")
    replay = p.add_argument_group("replay")
    many = p.add_argument_group("many pairs (docs/performance.md)")
    output = p.add_argument_group("output")
    p.add_argument("block", nargs="?", type=READ_FILE, help="the block: its ST source, or the PLCopen XML of generate --format plcopen")
    data.add_argument("--data", action="append", type=RECORDING,
                      help=f"the recording ({described()} of columns), one row per call; columns Enable "
                           "and Reset (0/1), when present, drive those block inputs. Repeat it, or give a "
                           "folder, for a campaign: each run replayed from a freshly started block, one line "
                           "per run, one verdict")
    data.add_argument("--runs", metavar="TABLE", type=RUNS_TABLE,
                      help="a campaign's runs table (fit --runs) instead of --data: each run verified from a "
                           "fresh block")
    reading_arguments(data)
    data.add_argument("--resample", **{**RESAMPLE, "help": "with --model: take raw logger data onto the block's "
                                                            "cycle of SECONDS by the rule fit --resample records (a "
                                                            "model fitted with --resample applies it without this "
                                                            "option)"})
    against.add_argument("--model", type=READ_FILE, help="compare with this model's float32 reference")
    output.add_argument("--outputs", metavar="FILE", type=Writes(named("a file for the outputs (.csv or .parquet)")),
                        help="also write what the block output at each call of the replay (one recording), "
                             "beside the time column: CSV (REAL to 9 digits, every bit kept) or Parquet")
    against.add_argument("--expect", type=columns,
                         help="compare with recorded outputs: COLUMN or OUTPUT=COLUMN, comma-separated")
    data.add_argument("--inputs", type=mapping, help="block input to column mapping NAME=COLUMN,...")
    many.add_argument("--manifest", type=Reads("manifest", named("a manifest (CSV)")),
                      help="CSV of pairs to verify (columns block,data and model or expect, optional inputs)")
    many.add_argument("--jobs", type=number(int, 1, 256, "processes"), default=1,
                      help="with --manifest: pairs verified in parallel (default: %(default)s)")
    many.add_argument("--scheduler", metavar="ADDRESS", type=scheduler_address,
                      help="with --manifest or a campaign: verify the pairs as tasks of the Dask distributed "
                           "cluster whose scheduler is at ADDRESS (tcp://HOST:PORT; the fleet extra); every "
                           "worker reads the files by the paths given")
    replay.add_argument("--engine", choices=("auto", "interp", "fast"), default="auto",
                        help="interp: the reference interpreter; fast: the block compiled to C (same bits); "
                             "auto: fast when a C compiler is there (default: %(default)s)")
    replay.add_argument("--faults", action="store_true",
                        help="replay with injected sensor faults (NaN, open/short PT100, jumps, paper 000 sine"
                             " and offset), Enable/Reset actions and, fused, probing faults; check exactness, "
                             "finiteness, clamp and rate limit, and fail a case further from the measured drift "
                             "than no compensation that no status bit flags")
    replay.add_argument("--probe-every", type=every, metavar="WHEN",
                        help=f"a fused block (fit --probe) on a target measured at every call: replay a probing "
                             f"every {EVERY_HELP}; default: the schedule the model file records (a probed target's "
                             f"own measured rows, or columns ProbeValue and ProbeNew, need none)")
    against.add_argument("--time", help="time column: of --expect traces (default: time_s), or, with --model, of data "
                                        "whose time column is named otherwise than the model's (a seconds file for a "
                                        "model fitted on a date-time export)")
    json_output.add_arguments(output)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        read = files_read(args)  # before args.data becomes the one run: no output may replace any of them
        if args.scheduler and args.jobs != 1:
            raise UserError("--scheduler and --jobs: the cluster's workers verify the pairs; give one of the two")
        if args.manifest:
            return _fleet(args, read)
        if not args.block or not (args.data or args.runs):
            raise UserError("verify needs BLOCK and --data (or --runs TABLE; or --manifest FILE for many pairs)")
        if (args.model is None) == (args.expect is None):
            raise UserError("verify needs either --model MODEL.json or --expect COLUMN[,COLUMN] (a recorded PLC trace)")
        if args.expect and args.probe_every is not None:
            raise UserError("--probe-every makes up the probings of a replay against a model; a PLC trace (--expect) "
                            "holds the probings the PLC saw: give them as columns ProbeValue and ProbeNew (or map "
                            "them with --inputs ProbeValue=COLUMN,ProbeNew=COLUMN)")
        runs = _runs(args)
        if len(runs) > 1 or args.runs:
            return _campaign(args, runs)
        if args.jobs != 1 or args.scheduler:
            raise UserError(f"{'--jobs' if args.jobs != 1 else '--scheduler'} runs the pairs of a --manifest or the "
                            f"runs of a campaign in parallel")
        args.data = runs[0]
        _check_outputs_file(args, read)
        return _against_model(args) if args.model else _against_trace(args)
    except UserError as exc:  # a model file that lacks what its kind needs: name the file
        raise UserError(str(exc).replace("model file:", f"{args.model}:", 1) if args.model else str(exc)) from None


def _check_outputs_file(args: argparse.Namespace, read: list[str]) -> None:
    """--json and --outputs by the one output rule, before any work."""
    from thermoplc.base.fileio import check_outputs
    from thermoplc.verifier.replays.outputs_file import check_name
    if args.outputs is not None:
        if args.faults:
            raise UserError("--outputs writes one replay's outputs; --faults replays once per fault")
        check_name(args.outputs)
    check_outputs({"--json": json_output.file(args), "--outputs": args.outputs}, args.force,
                  inputs=read)


def _written_outputs(args: argparse.Namespace, report, table, time_column: str) -> str:
    """Write --outputs (when given) from what the replay produced; the line that says so."""
    if args.outputs is None:
        return ""
    import numpy as np
    from thermoplc.base.fileio import write_outputs
    from thermoplc.verifier.replays.outputs_file import columns, encoded
    if not report.produced:
        raise UserError(f"{args.block}: the block stopped before its outputs could be written ({report.failure})")
    times = table.columns.get(time_column, np.arange(table.rows, dtype=float))
    found = columns(report.produced, times[:len(next(iter(report.produced.values())))], time_column)
    write_outputs([(args.outputs, encoded(found, args.outputs))])
    return f"\n  wrote {args.outputs}: the block's {len(found) - 1} outputs at each of {len(times)} calls"


def _runs(args: argparse.Namespace) -> list[str]:
    """The recordings to replay, as `fit` reads them: --data (files, folders; a folder's runs.csv) or the
    runs table's files."""
    from thermoplc.recordings.campaign import run_list
    return list(run_list(args.data, args.runs).paths)


def _campaign(args: argparse.Namespace, runs: list[str]) -> int:
    """A campaign: every run replayed from a fresh block (a pair each, as a manifest's), one line per run
    and one verdict: 1 when any run is not bit-exact, else 2 when a run could not be read, else 0."""
    if args.json or args.faults or args.outputs:
        raise UserError("--json, --faults and --outputs take one recording; a campaign's runs are listed one line "
                        "each (verify a run alone for its --json, --faults or --outputs)")
    if "-" in runs:
        raise UserError("--data -: standard input holds one recording; give a campaign's runs as files")
    from thermoplc.recordings.campaign import run_labels
    from thermoplc.verifier.fleets.fleet import Pair, verify_fleet
    expect = dict(item.partition("=")[::2] if "=" in item else (item, item) for item in args.expect or ()) or None
    pairs = [Pair(k, args.block, path, args.model, expect, args.inputs, reading=tuple(given_reading(args).items()),
                  probe_every=args.probe_every, resample_s=args.resample) for k, path in enumerate(runs, start=1)]
    outcomes, seconds = verify_fleet(pairs, min(args.jobs, len(pairs)), args.engine, args.scheduler)
    labels = run_labels(runs)
    width = max(len(label) for label in labels) + 2
    print(f"campaign: {args.block} against {args.model or 'the recorded outputs'} on {len(runs)} runs, each from a "
          f"freshly started block")
    print(f"  {'run':<{width}}{'status':<15}detail")
    for label, o in zip(labels, outcomes):
        print(f"  {label:<{width}}{o.status:<15}{o.detail}")
    for line in _block_lines(outcomes):
        print(line)
    counts = {s: sum(o.status == s for o in outcomes) for s in ("bit-exact", "NOT bit-exact", "error")}
    if counts["NOT bit-exact"]:
        verdict, status = "NOT bit-exact", 1
    elif counts["error"]:
        verdict, status = "NOT VERIFIED (a run could not be read)", 2
    else:
        verdict, status = "bit-exact: every run reproduces the reference", 0
    detail = "" if status == 0 else ", ".join(f"{n} {s}" for s, n in counts.items() if n) + "; "
    print(f"{verdict} ({detail}{len(outcomes)} runs, {seconds:.1f} s)")
    return status


def _block_lines(outcomes) -> list[str]:
    """What the block itself says, read once from a run's full report: the safety limits read from its
    constants (they decide what the reference is compared in) and the constants checked against the model."""
    texts = [o.text for o in outcomes if o.status != "error"]
    wanted = ("  safety limits read from the block", "  constants and tables")
    return [line for line in texts[0].splitlines() if line.startswith(wanted)] if texts else []


def _fleet(args: argparse.Namespace, read: list[str]) -> int:
    """Many pairs from a manifest: 2 when any pair could not be read, else 1 when any is not bit-exact."""
    if args.block or args.data or args.runs or args.model or args.expect or args.faults or args.outputs:
        raise UserError("--manifest lists the blocks, data and models itself; give no BLOCK, --data, --model, --expect, "
                        "--faults or --outputs (verify one pair alone for its --outputs)")
    from thermoplc.verifier.fleets.fleet import fleet_document, format_fleet, read_manifest, verify_fleet
    pairs = read_manifest(args.manifest, tuple(given_reading(args).items()), args.probe_every, args.resample)
    json_output.check(args, read)
    outcomes, seconds = verify_fleet(pairs, args.jobs, args.engine, args.scheduler)
    json_output.emit(args, format_fleet(outcomes, args.manifest, seconds), fleet_document(outcomes, args.manifest))
    if any(o.status == "error" for o in outcomes):
        return 2
    return 0 if all(o.status == "bit-exact" for o in outcomes) else 1


def _against_model(args: argparse.Namespace) -> int:
    """The block against the model's float32 reference: streamed when the recording allows it
    (verifier/replays/stream.py), else read whole; with --faults, replayed once per injected fault."""
    from thermoplc.models.modelfile import load_model
    from thermoplc.verifier.replays.documents import verify_document
    from thermoplc.recordings.resample import RULE
    from thermoplc.verifier.replays.recording import read_recording, resampling_for
    from thermoplc.verifier.replays.replay import other_model, verify_against_model
    model = load_model(args.model)
    if args.time is not None:  # the data's time column, where the model's was named otherwise
        model = replace(model, time_column=args.time)
    rule = resampling_for(model, args.resample)
    reading = reading_of(args, model)
    report, table = None, None
    origin = other_model(args.block, model, args.model)
    try:
        if not args.faults and args.outputs is None and rule is None:
            from thermoplc.verifier.replays.stream import verify_streaming
            report = verify_streaming(args.block, model, args.model, args.data, args.inputs, args.engine,
                                      reading, progress()).report
        if report is None:
            table = read_recording(args.data, model, progress(), reading, args.resample, args.inputs, args.model)
            if args.faults:
                return _faults(args, model, table)
            report = verify_against_model(args.block, model, args.model, table, args.inputs, args.engine,
                                          args.probe_every)
    except UserError as exc:  # the other model first: it explains the refusal
        raise UserError(f"{origin}; {exc}" if origin else str(exc)) from None
    report = replace(report, origin=origin)
    said = (f"\n  {args.data} taken onto the block's cycle of {rule.period_s:g} s first ("
            f"{'the model file' if model.resample else '--resample'}: {RULE})" if rule else "")
    said += _read_as(reading, model, table)
    said += _written_outputs(args, report, table, model.time_column)
    resampled = {"resampled": {"period_s": rule.period_s, "by": "model file" if model.resample else "--resample"}} \
        if rule else {}
    return _result(args, report.text() + said, report.ok,
                   lambda: {**verify_document(report), **resampled, **_outputs_named(args)})


def _read_as(reading, model, table) -> str:
    """What the reader converted, and the reading options the model file gave (not the command line)."""
    from thermoplc.recordings.table import reading_notes
    option = lambda key, value: f"--{key.replace('_', '-')} {value}"
    recorded = {k: v for k, v in model.reading.to_doc().items() if reading.written()[k] == v}
    overridden = [(k, v, model.reading.written()[k]) for k, v in reading.written().items()
                  if v != model.reading.written()[k]]
    said = "".join(f"\n  {line}" for line in reading_notes([table] if table is not None else []))
    if recorded:
        said += "\n  read as the model file records: " + ", ".join(option(k, v) for k, v in recorded.items())
    if overridden:
        said += "\n  NOTE: read otherwise than the model's data were: " + ", ".join(
            f"{option(k, given)} given here, {option(k, was)} in the model file" for k, given, was in overridden)
    return said


def _faults(args: argparse.Namespace, model, table) -> int:
    from thermoplc.verifier.replays.documents import faults_document
    from thermoplc.verifier.replays.faults import verify_faults
    report = verify_faults(args.block, model, table, args.inputs, args.engine, args.probe_every)
    return _result(args, report.text(), report.ok, lambda: faults_document(report))


def _against_trace(args: argparse.Namespace) -> int:
    """The block against the outputs a PLC recorded (--expect OUTPUT=COLUMN,...)."""
    from thermoplc.recordings.table import read_table
    from thermoplc.verifier.replays.documents import verify_document
    from thermoplc.verifier.replays.replay import verify_against_trace
    if args.faults:
        raise UserError("--faults needs --model: the faulty replay is compared with the model's reference")
    if args.resample:
        raise UserError("--resample takes raw data onto a model's cycle (--model); a PLC trace (--expect) is recorded "
                        "on the block's cycle already")
    time_column = args.time or "time_s"
    table = read_table(args.data, time_column, reading=reading_of(args))
    expect = {}
    for item in args.expect:
        output, sep, column = item.partition("=")
        output = output if sep else item
        if output.upper() in {k.upper() for k in expect}:
            raise UserError(f"--expect names output {output!r} twice; give each output one column")
        expect[output] = column if sep else item
    report = verify_against_trace(args.block, table, expect, args.inputs, time_column, args.engine)
    said = _written_outputs(args, report, table, time_column)
    return _result(args, report.text() + said, report.ok, lambda: {**verify_document(report), **_outputs_named(args)})


def _outputs_named(args: argparse.Namespace) -> dict:
    """`verify --json`: the file --outputs wrote the block's outputs to, when given."""
    return {"outputs_file": args.outputs} if args.outputs is not None else {}


def _result(args: argparse.Namespace, text: str, ok: bool, document) -> int:
    """Print (and with --json write) the result: exit 0 bit-exact, 1 not."""
    json_output.emit(args, text, document() if args.json else None)
    return 0 if ok else 1
