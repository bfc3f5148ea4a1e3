"""`thermoplc generate`: a model file compiled into a checked Structured Text block (thermoplc.pipeline)."""
from __future__ import annotations

import math

import argparse
import datetime
import functools
import os
import sys
from typing import Callable

from thermoplc.base.errors import UserError
from thermoplc.base.fileio import check_output, write_atomic
from thermoplc.base.text import decode_lenient
from thermoplc.commands.reads import files_read
from thermoplc.commands.options import (FORCE_HELP, OUTPUT, READ_FILE, block_version, date, examples, header_attribute, number, st_name,
                                        value_range)


def add_parser(sub) -> None:
    p = sub.add_parser("generate", help="compile a model file into a Structured Text function block",
                       **examples("docs/commissioning.md",
                                  "thermoplc generate model.json -o ThermalComp.scl",
                                  "thermoplc generate model.json --dialect step7 -o ThermalComp.scl",
                                  "thermoplc generate model.json --dialect iec --format plcopen -o ThermalComp.xml"))
    p.add_argument("model", type=READ_FILE, help="model file written by fit or diagnose")
    # the dialects' records: their names, what each is for, and which of them an option applies to
    from thermoplc.generator.dialects import named_where, plcopen_wrapped, registry
    p.add_argument("--dialect", choices=tuple(registry()), default=next(iter(registry())),
                   help="; ".join(f"{name}: {record.help}" for name, record in registry().items())
                        + " (default: %(default)s)")
    p.add_argument("--format", choices=("st", "plcopen"), default="st",
                   help=f"st: source text; plcopen: PLCopen TC6 XML of the {plcopen_wrapped().name} block "
                        "(default: %(default)s)")
    p.add_argument("--max-offset-um", type=number(float, 1e-6, 1e12, "micrometres"),
                   help="clamp every output to +-this (um; urad for angles) (default: 1.5 x the largest drift the "
                        "model file's recording reached, measured or modelled, rounded up; 300 for a model file "
                        "without an envelope)")
    p.add_argument("--max-step-um", type=number(float, 1e-6, 1e12, "micrometres"),
                   help="largest change of an output per call (default: 1.5 x the fastest measured change per call of "
                        "the model file's recording, rounded up; 2 for a model file without an envelope)")
    p.add_argument("--max-speed-rpm", type=number(float, 1e-6, 1e12, "rpm"),
                   help="a speed input beyond +-this is a sensor fault (default: 1.5 x the largest speed of the model "
                        "file's recording, rounded up; 100000 for a model file without an envelope)")
    p.add_argument("--temp-range", type=value_range, default=(-40.0, 150.0), metavar="LOW,HIGH",
                   help="plausible temperatures, degC; outside = sensor fault (default: -40,150)")
    p.add_argument("--max-jump-k", type=number(float, 1e-6, 1e6, "kelvin"), default=1.0,
                   help="temperature change per call that marks a sensor faulty, K (default: %(default)s)")
    p.add_argument("--settle-calls", type=number(int, 1, 10000, "calls"), default=30,
                   help="steady calls before a faulty sensor is trusted again (default: %(default)s)")
    p.add_argument("--stuck-calls", type=number(int, 2, 32767, "calls"),
                   help="a temperature that repeats its reading this many times in a row is a stuck sensor "
                        "(default: 1.5 x the longest run of repeated readings in the model file's recording, at least "
                        "10 min of calls; 1 h of calls for a model file that does not record it)")
    p.add_argument("--fault-move-um", type=number(float, 1e-6, 1e12, "micrometres"), default=2.0,
                   help="while an input's fault bit is set, each output stays within this of its value before the "
                        "fault (default: %(default)s)")
    p.add_argument("--fault-fade-s", type=number(float, 1.0, 1e9, "seconds"), default=1800.0,
                   help="while the fault lasts, that value fades to no compensation with this time constant, s "
                        "(default: %(default)s)")
    p.add_argument("--name", help="function block name (default: the model file's, set by fit --name); one block "
                                  "per axis needs one name each")
    p.add_argument("--retain", action="store_true",
                   help="keep the state over a power cycle: statics and outputs declared RETAIN "
                        f"({named_where(lambda d: d.retain)})"
                        + (f"; {without}: the header says to keep the instance DB retentive"
                           if (without := named_where(lambda d: not d.retain)) else ""))
    p.add_argument("--instance-db", metavar="NAME", type=st_name,
                   help=f"{named_where(lambda d: d.instance_db) or 'no dialect'}: append the source of an instance "
                        "DB NAME of the block (enter NAME in the symbol table); its header attributes are the block's")
    p.add_argument("--author", type=header_attribute, default="thermopl",
                   help="AUTHOR in the block header, at most 8 letters, digits or '_' (default: %(default)s)")
    p.add_argument("--family", type=header_attribute, default="ThermCmp",
                   help="FAMILY in the block header, at most 8 letters, digits or '_' (default: %(default)s)")
    p.add_argument("--header-name", type=header_attribute, metavar="NAME",
                   help=f"NAME in the block header ({named_where(lambda d: d.attributes) or 'no dialect'}), at most 8 "
                        "letters, digits or '_' (default: the block name cut to 8 characters, which the summary "
                        "states)")
    p.add_argument("--block-version", type=block_version, metavar="X.Y",
                   help="VERSION in the block header, each part 0 to 15 (default: a counter that only goes up: 0.1 for "
                        "a new block; replacing a block thermoplc wrote (--force), its version for the same model, "
                        "the next one (0.9 -> 0.10, 0.15 -> 1.0) for a changed model)")
    p.add_argument("--date", type=date, metavar="YYYY-MM-DD",
                   help="date in the header comment (default: today, or SOURCE_DATE_EPOCH when set)")
    p.add_argument("--stats", action="store_true",
                   help="print operations per call, bytes of state, the range proof and the stress replay")
    p.add_argument("--accept-unvalidated", action="store_true",
                   help="write the block although the model file has no held-out evidence that it beats no "
                        "compensation (or has evidence that it does not); the header says so")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("--explain", action="store_true", help="print which region computes which model term, "
                                                          "with its constants")
    p.add_argument("-o", "--output", required=True, type=OUTPUT, help="source file to write (.scl, .st or .xml)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace
    from thermoplc.base.identifiers import identifier_problem
    from thermoplc.generator.ir import Identity
    from thermoplc.models.modelfile import load_model
    from thermoplc.models.safety import Limits
    from thermoplc.pipeline import generate
    to_stdout = args.output == "-"  # the block on standard output, what generate says on standard error
    if not to_stdout:
        check_output(args.output, args.force, inputs=files_read(args))
    say = functools.partial(print, file=sys.stderr if to_stdout else sys.stdout)
    model = load_model(args.model)
    if args.name is not None:
        problem = identifier_problem(args.name)
        if problem:
            raise UserError(f"--name {args.name!r} {problem}")
        model = replace(model, block_name=args.name)
    low, high = args.temp_range
    limits = Limits.for_model(model, max_output=args.max_offset_um, max_step=args.max_step_um,
                              max_speed_rpm=args.max_speed_rpm, temp_min_C=low, temp_max_C=high,
                              max_jump_K=args.max_jump_k, settle_calls=args.settle_calls, stuck_calls=args.stuck_calls,
                              fault_move=args.fault_move_um,
                              fault_fade=math.exp(-model.sample_period_s / args.fault_fade_s))
    version, why = _version(args, model)
    identity = Identity(author=args.author, family=args.family, version=version, date=args.date or _today(),
                        name=args.header_name or "")
    generated = generate(model, args.model, limits, args.dialect, args.format == "plcopen", identity, args.retain,
                         args.instance_db, args.accept_unvalidated, args.output)
    if to_stdout:
        sys.stdout.write(generated.text)
    else:
        write_atomic(args.output, generated.text)
    _summary(say, args, model, limits, generated, why)
    return 0


def _version(args: argparse.Namespace, model) -> tuple[tuple[int, int], str]:
    """The block's VERSION and why, as the summary says it: --block-version, else the counter of
    generator/identity.py on the block this one replaces (read before anything is written)."""
    from thermoplc.generator.identity import FIRST_VERSION, next_version, read_replaced
    from thermoplc.generator.ir import GenerationError
    if args.block_version:
        return args.block_version, "--block-version"
    if args.format == "plcopen":
        return FIRST_VERSION, ""  # PLCopen XML carries no VERSION
    if args.output == "-":
        return FIRST_VERSION, "written to standard output: no block to replace; --block-version sets it"
    replaced = None
    if os.path.isfile(args.output):  # check_output let it through: --force, a regular file
        with open(args.output, "rb") as handle:
            replaced = read_replaced(decode_lenient(handle.read(REPLACED_HEAD)))
    try:
        return next_version(replaced, model.fingerprint(), args.output)
    except GenerationError as exc:
        raise UserError(f"{exc}; nothing written") from None


REPLACED_HEAD = 1 << 16  # bytes of the replaced file read for its header: a block's header is its first lines


def _summary(say: Callable[[str], None], args: argparse.Namespace, model, limits, generated, why: str) -> None:
    """What was written, its VERSION and NAME and within which limits; the cost, proof and stress
    replay with --stats; the regions with --explain."""
    from thermoplc.generator.dialects import registry
    from thermoplc.generator.identity import NAME_MAX, header_name, show
    from thermoplc.generator.lower import lower_model
    from thermoplc.fitting.acceptance import evidence, fused_summary
    from thermoplc.models.safety import stuck_checked
    block, proof, stressed = generated.block, generated.proof, generated.stressed
    say(f"wrote {'standard output' if args.output == '-' else args.output}: {model.kind} block {model.block_name!r}, "
        f"dialect {args.dialect}{', PLCopen XML' if args.format == 'plcopen' else ''}, model fingerprint "
        f"{model.fingerprint()}")
    if args.format != "plcopen":  # the XML has no VERSION or NAME
        say(f"  VERSION {show(block.identity.version)} ({why})")
    if registry()[args.dialect].attributes:  # IEC text names its version in a comment, and has no NAME
        name, cut = header_name(block.name, block.identity.name)
        say(f"  NAME {name}: " + (f"the block name cut to the {NAME_MAX} characters STEP 7 allows; --header-name sets it"
                                  if cut else "--header-name" if block.identity.name else "the block name"))
    for field, option in (("max_output", "--max-offset-um"), ("max_step", "--max-step-um"),
                          ("max_speed_rpm", "--max-speed-rpm"), ("stuck_calls", "--stuck-calls")):
        if limits.origin(field):
            say(f"  {option} {getattr(limits, field):g}: {limits.origin(field)}")
    if model.start is None:
        say("  no known start in the model file (written before thermoplc fitted one): after power-on or Reset the "
            "block starts at the model's own first value; refit to get one")
    say(f"  outputs within +-{limits.max_output:g}, at most {limits.max_step:g} per call; temperatures "
        f"{limits.temp_min_C:g}..{limits.temp_max_C:g} degC, jump {limits.max_jump_K:g} K per call"
        + (f", stuck after {limits.stuck_calls} repeats of a reading" if stuck_checked(model) else "")
        + f"; while a fault "
        f"bit is set within {limits.fault_move:g} of the output before it, fading to none in {args.fault_fade_s:g} s")
    say("  " + (f"NOT VALIDATED (--accept-unvalidated): {generated.unvalidated}" if generated.unvalidated
                else f"accepted on {evidence(model).summary()}"))
    if model.probe is not None and not generated.unvalidated:
        say(f"  fused {fused_summary(model)}")
    if args.stats:
        from thermoplc.generator.stats import block_stats, format_stats
        say(format_stats(block_stats(block), block_stats(lower_model(model))))
        say(format_proof(proof, block))
        say(f"stress replay: {stressed.rows} calls with every input at the ends, the middle or random points of its "
            f"guard range and random Reset and Enable, no NaN, Inf or "
            f"INT overflow; outputs seen: " + ", ".join(f"{name} {low:.6g}..{high:.6g}"
                                                       for name, (low, high) in stressed.output_ranges.items()))
    if args.explain:
        from thermoplc.generator.explain import explain
        say(explain(block))


def _today() -> str:
    """Today in UTC, or the date of SOURCE_DATE_EPOCH (reproducible builds) when it is set."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    if epoch is None:
        return datetime.datetime.now(datetime.timezone.utc).date().isoformat()
    try:
        return datetime.datetime.fromtimestamp(int(epoch), datetime.timezone.utc).date().isoformat()
    except (ValueError, OverflowError, OSError):
        raise UserError(f"SOURCE_DATE_EPOCH={epoch!r}: expected whole seconds since 1970-01-01 UTC, up to the "
                        f"year 9999; or give --date YYYY-MM-DD") from None


def format_proof(proof, block) -> str:
    """The range proof in one line: what cannot happen, and the ranges of the model values and the outputs."""
    from thermoplc.generator.safety import model_values
    show = lambda name: f"{name} {proof.ranges[name][0]:.6g}..{proof.ranges[name][1]:.6g}"
    values = model_values(block)
    return (f"range proof: for every input inside its guard range and on every call (state bounds hold after "
            f"{proof.steps} joined calls), no Inf, NaN, division by 0, subnormal product or integer overflow; "
            f"model values before the limits: " + ", ".join(show(values[v.name]).replace(values[v.name], v.name, 1)
                                                              for v in block.outputs if v.name in values)
            + "; outputs: " + ", ".join(show(v.name) for v in block.outputs if v.type == "REAL"))
