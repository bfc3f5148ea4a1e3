"""The `thermoplc` command: thin wrappers over the library, one subcommand each."""
from __future__ import annotations

import argparse
import datetime
import errno
import functools
import math
import os
import re
import signal
import sys
from pathlib import Path

from thermoplc.base.version import __version__
from thermoplc.base.errors import UserError
from thermoplc.base.fileio import REPORT_MANIFEST, check_output, check_report_folder, write_atomic


MAX_TWIN_ROWS = 50_000_000  # about 1.6 years at 1 s; beyond it the arrays alone need tens of GB


def _columns(text: str) -> tuple[str, ...]:
    if text.startswith("@"):  # a file written by select-sensors -o; its '#' lines are comments
        try:
            text = Path(text[1:]).read_text("utf-8").strip()
        except OSError as exc:
            raise argparse.ArgumentTypeError(f"cannot read {text[1:]}: {exc.strerror}") from None
        text = ",".join(line for line in text.splitlines() if not line.lstrip().startswith("#"))
    names = tuple(c.strip() for c in text.split(",") if c.strip())
    if not names:
        raise argparse.ArgumentTypeError("expected comma-separated column names")
    return names


def _number(kind, low: float, high: float, what: str = ""):
    """An argparse type: a finite int or float within [low, high] (the option is named by argparse)."""
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {'an integer' if kind is int else 'a number'}, found {text!r}") from None
        if not (math.isfinite(value) and low <= value <= high):
            shown = (lambda v: f"{int(v):,}") if kind is int else (lambda v: f"{v:g}")
            raise argparse.ArgumentTypeError(f"expected {what or 'a value'} from {shown(low)} to {shown(high)}, found {text}")
        return value
    return parse


SEED = _number(int, 0, 2 ** 32 - 1, "a seed")
SECONDS = _number(float, 0.0, 1e9, "seconds")
ROWS = _number(int, 1, 10 ** 9, "a row count")


def _range(text: str) -> tuple[float, float]:
    try:
        low, high = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LOW,HIGH (two numbers), found {text!r}") from None
    if not (math.isfinite(low) and math.isfinite(high) and -1e6 <= low < high <= 1e6) \
            or any(0 < abs(end) < 1e-6 for end in (low, high)):
        raise argparse.ArgumentTypeError(f"expected LOW,HIGH with LOW below HIGH, finite, within +-1e6 and each 0 or "
                                         f"at least 1e-6 in size, found {text!r}")
    return low, high


def _attribute(text: str) -> str:
    from thermoplc.base.identifiers import header_attribute_problem
    problem = header_attribute_problem(text)
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return text


def _block_version(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d{1,2})\.(\d{1,2})", text)
    if not match or not all(0 <= int(part) <= 15 for part in match.groups()):
        raise argparse.ArgumentTypeError(f"expected X.Y with each part 0 to 15, found {text!r}")
    return int(match.group(1)), int(match.group(2))


def _date(text: str) -> str:
    try:
        datetime.date.fromisoformat(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a date YYYY-MM-DD, found {text!r}") from None
    if not re.fullmatch(r"\d{4}-\d{2}-\d{2}", text):
        raise argparse.ArgumentTypeError(f"expected a date YYYY-MM-DD, found {text!r}")
    return text


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


def _mapping(text: str) -> dict:
    mapping = {}
    for item in text.split(","):
        name, sep, column = item.partition("=")
        if not sep or not name.strip() or not column.strip():
            raise argparse.ArgumentTypeError(f"expected NAME=COLUMN[,NAME=COLUMN...], found {item!r}")
        if name.strip().upper() in {k.upper() for k in mapping}:
            raise argparse.ArgumentTypeError(f"{name.strip()!r} is mapped twice")
        mapping[name.strip()] = column.strip()
    return mapping


def cmd_twin(args) -> int:
    from thermoplc.machines import machine
    from thermoplc.machines.faults import SensorFault
    from thermoplc.models.table import write_table
    from thermoplc.models.effects import Effect
    chosen = machine(args.machine)
    if args.hours * 3600 / args.dt > MAX_TWIN_ROWS:  # each option is checked by its type; their ratio here
        raise UserError(f"--hours {args.hours:g} at --dt {args.dt:g} gives more than {MAX_TWIN_ROWS:,} rows; "
                        f"use a longer --dt or fewer hours")
    faults = tuple(SensorFault.parse(f, chosen.SENSORS) for f in args.sensor_fault)
    effects = tuple(Effect.parse(e, chosen.COLUMN_DEFAULTS) for e in args.effect)
    names = [e.name for e in effects]
    if len(set(names)) != len(names):
        raise UserError("--effect: each effect can be switched on once")
    check_output(args.output, args.force)
    options = {} if args.ambient_swing is None else {"ambient_swing": args.ambient_swing}
    columns = chosen.simulate(args.hours, args.seed, args.dt, args.ambient_start, faults=faults, effects=effects,
                              noise=args.noise, **options)
    write_atomic(args.output, write_table(columns))
    rows = len(columns["time_s"])
    print(f"wrote {args.output}: {rows} rows, {args.hours:g} h every {args.dt:g} s, seed {args.seed}, "
          f"machine {chosen.NAME}")
    for e in effects:
        print(f"  hidden effect {e.name}: " + ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                                     for k, v in e.parameters))
    print(f"  columns: {', '.join(columns)}")
    return 0


def _progress(message: str) -> None:
    print(f"\r  {message:<70}", end="", file=sys.stderr, flush=True)


def cmd_fit(args) -> int:
    from thermoplc.models.crossval import fit_held_out
    from thermoplc.models.fit import FitRequest
    from thermoplc.models.kalman import FitOptions
    from thermoplc.generator.lower import check_model_becomes_block
    from thermoplc.models.table import read_table
    check_output(args.output, args.force, inputs=args.data)
    tables = [read_table(path, args.time, decimal=args.decimal) for path in args.data]
    options = FitOptions(args.optimizer, args.seed, args.population, args.generations, args.jump_limit,
                         args.recover_limit, args.ga_operators)
    request = FitRequest(kind=args.model, target=args.target[0], temps=args.temps, speed=args.speed,
                         ambient=args.ambient, train_until=args.train_until, train_rows=args.train_rows,
                         block_name=args.name, options=options, bins=args.bins, precision_um=args.precision_um,
                         lags=args.lags, lag_step_s=args.lag_step, extra_targets=args.target[1:],
                         tool_length=args.tool_length, unseen=args.unseen, time_bins=args.time_bins)
    progress = _progress if sys.stderr.isatty() else None
    if args.model == "auto":
        model = _fit_auto(tables, request, args, progress)
    else:
        model = fit_held_out(tables, request, args.folds, args.time, progress)
    if sys.stderr.isatty():
        print(file=sys.stderr)
    check_model_becomes_block(model, args.output)
    write_atomic(args.output, model.to_json())
    print(format_fit(model))
    print(f"wrote {args.output}")
    from thermoplc.models.acceptance import refusal
    refused = refusal(model)
    if refused:
        print(f"thermoplc: WARNING: generate will refuse this model: {refused}", file=sys.stderr)
    return 0


AUTO_TOLERANCE = 0.1  # a cheaper model within this share of the best held-out RMSE is named beside it


def _fit_auto(tables, request, args, progress):
    """`fit --model auto`: the ranking printed with each candidate's PLC cost; the best returned."""
    from thermoplc.generator.lower import lower_model
    from thermoplc.generator.stats import block_stats
    from thermoplc.models.auto import rank
    ranked = rank(tables, request, args.folds, args.time, say=progress)
    if sys.stderr.isatty():
        print(file=sys.stderr)
    fitted = [c for c in ranked if c.model is not None]
    if not fitted:
        raise UserError("--model auto: no kind could be fitted: " + "; ".join(f"{c.kind} ({c.refused})" for c in ranked))
    cost = {id(c): block_stats(lower_model(c.model))["arithmetic_per_call"] for c in fitted}
    none = fitted[0].model.metrics["held_out"].get("zero_rmse_um")
    print(f"auto: {len(ranked)} candidates ranked by held-out RMSE"
          + (f" (no compensation {none:.3f} um)" if none is not None else ""))
    print(f"  {'rank':<6}{'kind':<8}{'sensors':<32}{'RMSE um':>9}{'max um':>9}{'ops/call':>10}")
    for k, c in enumerate(ranked, start=1):
        if c.model is None:
            print(f"  {'-':<6}{c.kind:<8}{','.join(c.sensors):<32}  refused: {c.refused}")
            continue
        held = c.model.metrics["held_out"]
        print(f"  {k:<6}{c.kind:<8}{','.join(c.sensors):<32}{held['rmse_um']:>9.3f}{held['max_abs_um']:>9.3f}"
              f"{cost[id(c)]:>10}" + (f"  generate refuses: {c.not_accepted}" if c.not_accepted else ""))
    best = fitted[0]
    cheaper = min((c for c in fitted if c.rmse <= (1 + AUTO_TOLERANCE) * best.rmse and
                   (c.not_accepted is None) == (best.not_accepted is None)), key=lambda c: cost[id(c)])
    if cheaper is not best:
        print(f"  cheapest within {AUTO_TOLERANCE:.0%} of the best: {cheaper.kind} on {','.join(cheaper.sensors)}, "
              f"{cheaper.rmse:.3f} um, {cost[id(cheaper)]} operations per call (fit it with --model {cheaper.kind} "
              f"--temps {','.join(cheaper.sensors)})")
    print(f"  writing the best: {best.kind} on {','.join(best.sensors)}")
    return best.model


def format_fit(model) -> str:
    m = model.metrics
    batches = model.training.get("batches", [model.training])
    files = ", ".join(t["file"] for t in batches)
    lines = [f"fitted {model.kind} on {files}: {m['train']['rows']} training rows "
             f"(until {batches[0]['until_s']:g} s{' in each file' if len(batches) > 1 else ''}), "
             f"{m['held_out']['rows']} held out" + (" in cross-validation" if "cross_validation" in m else ""),
             f"  {'':<22}{'RMSE um':>10}{'max |residual| um':>20}"]
    held_label = "prediction (all folds)" if "cross_validation" in m else "prediction (held out)"
    for label, key in (("fit (training)", "train"), (held_label, "held_out")):
        if m[key]["rows"]:
            lines.append(f"  {label:<22}{m[key]['rmse_um']:>10.3f}{m[key]['max_abs_um']:>20.3f}")
    if "cross_validation" in m:
        lines += _format_folds(m)
    lines.append(f"  float32 block vs float64 model: max {m['float32_vs_float64_max_um']:.3g} um")
    if "one_step_rmse_K" in model.fit:  # an identified model: how far its temperatures are from the readings
        names = [s.name for s in model.signals("temperature")]
        each = lambda key: ", ".join(f"{n} {v:.3f}" for n, v in zip(names, model.fit[key]))
        gains = ", ".join(f"{n} {model.coef(f'KF_{i}', 'f64'):.3g}" if f"KF_{i}" in model.coefficients else f"{n} 0"
                          for i, n in enumerate(names, start=1))
        lines += [f"  temperatures (training), RMSE K: filtered one step ahead: {each('one_step_rmse_K')}; "
                  f"open loop: {each('open_loop_rmse_K')}",
                  f"  filter gain (share of the reading taken each call): {gains}"]
    return "\n".join(lines)


def _format_folds(m: dict) -> list[str]:
    """Each fold's held-out errors beside no compensation, and the pooled line with the spread."""
    held = m["held_out"]
    lines = [f"  {held['protocol']}: each fold predicted by a fit that never saw it",
             f"  {'fold (rows predicted)':<26}{'fitted rows':>12}{'RMSE um':>10}{'max um':>9}{'none RMSE um':>14}{'none max um':>13}"]
    lines += [f"  {f['label']:<26}{f['train_rows']:>12}{f['rmse']:>10.3f}{f['max_abs']:>9.3f}{f['zero_rmse']:>14.3f}"
              f"{f['zero_max_abs']:>13.3f}" for f in m["cross_validation"]]
    low, high = held["fold_rmse_um"]
    lines.append(f"  {'all folds':<26}{held['rows']:>12}{held['rmse_um']:>10.3f}{held['max_abs_um']:>9.3f}"
                 f"{held['zero_rmse_um']:>14.3f}{held['zero_max_abs_um']:>13.3f}")
    lines.append(f"  spread: fold RMSE {low:.3f} to {high:.3f} um")
    return lines


def format_proof(proof, block) -> str:
    from thermoplc.generator.safety import model_values
    show = lambda name: f"{name} {proof.ranges[name][0]:.6g}..{proof.ranges[name][1]:.6g}"
    values = model_values(block)
    return (f"range proof: for every input inside its guard range and on every call (state bounds hold after "
            f"{proof.steps} joined calls), no Inf, NaN, division by 0, subnormal product or integer overflow; "
            f"model values before the limits: " + ", ".join(show(values[v.name]).replace(values[v.name], v.name, 1)
                                                              for v in block.outputs if v.name in values)
            + "; outputs: " + ", ".join(show(v.name) for v in block.outputs if v.type == "REAL"))


def cmd_generate(args) -> int:
    from dataclasses import replace
    from thermoplc.base.identifiers import identifier_problem
    from thermoplc.generator.lower import lower_model, model_identity
    from thermoplc.models.acceptance import evidence
    from thermoplc.models.modelfile import load_model
    from thermoplc.models.safety import Limits
    from thermoplc.pipeline import generate
    to_stdout = args.output == "-"  # the block on standard output, what generate says on standard error
    if not to_stdout:
        check_output(args.output, args.force, inputs=[args.model])
    say = functools.partial(print, file=sys.stderr if to_stdout else sys.stdout)
    model = load_model(args.model)
    if args.name is not None:
        problem = identifier_problem(args.name)
        if problem:
            raise UserError(f"--name {args.name!r} {problem}")
        model = replace(model, block_name=args.name)
    low, high = args.temp_range
    limits = Limits(args.max_offset_um, args.max_step_um, low, high, max_jump_K=args.max_jump_k,
                    settle_calls=args.settle_calls)
    identity = model_identity(model, args.date or _today())
    identity = replace(identity, author=args.author, family=args.family,
                       version=args.block_version or identity.version)
    generated = generate(model, args.model, limits, args.dialect, args.format == "plcopen", identity, args.retain,
                         args.instance_db, args.accept_unvalidated, args.output)
    block, proof, stressed = generated.block, generated.proof, generated.stressed
    if to_stdout:
        sys.stdout.write(generated.text)
    else:
        write_atomic(args.output, generated.text)
    say(f"wrote {'standard output' if to_stdout else args.output}: {model.kind} block {model.block_name!r}, dialect {args.dialect}"
          f"{', PLCopen XML' if args.format == 'plcopen' else ''}, model fingerprint {model.fingerprint()}")
    say(f"  outputs within +-{limits.max_output:g}, at most {limits.max_step:g} per call; temperatures "
          f"{limits.temp_min_C:g}..{limits.temp_max_C:g} degC, jump {limits.max_jump_K:g} K per call")
    say("  " + (f"NOT VALIDATED (--accept-unvalidated): {generated.unvalidated}" if generated.unvalidated
                  else f"accepted on {evidence(model).summary()}"))
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
    return 0


def cmd_verify(args) -> int:
    try:
        return _verify(args)
    except UserError as exc:  # a model file that lacks what its kind needs: name the file
        raise UserError(str(exc).replace("model file:", f"{args.model}:", 1) if args.model else str(exc)) from None


def _verify(args) -> int:
    from thermoplc.models.table import read_table
    if args.manifest:
        if args.block or args.data or args.model or args.expect or args.faults:
            raise UserError("--manifest lists the blocks, data and models itself; give no BLOCK, --data, --model, --expect or --faults")
        from thermoplc.verifier.fleet import format_fleet, read_manifest, verify_fleet
        outcomes, seconds = verify_fleet(read_manifest(args.manifest), args.jobs, args.engine)
        print(format_fleet(outcomes, args.manifest, seconds))
        if any(o.status == "error" for o in outcomes):
            return 2
        return 0 if all(o.status == "bit-exact" for o in outcomes) else 1
    if not args.block or not args.data:
        raise UserError("verify needs BLOCK and --data (or --manifest FILE for many pairs)")
    if args.jobs != 1:
        raise UserError("--jobs runs the pairs of a --manifest in parallel; give --manifest FILE")
    from thermoplc.verifier.replay import verify_against_model, verify_against_trace
    if (args.model is None) == (args.expect is None):
        raise UserError("verify needs either --model MODEL.json or --expect COLUMN[,COLUMN] (a recorded PLC trace)")
    if args.model:
        from thermoplc.models.modelfile import load_model
        model = load_model(args.model)
        progress = _progress if sys.stderr.isatty() else None
        report = None
        if not args.faults:  # streamed in bounded memory when the recording allows it (verifier/stream.py)
            from thermoplc.verifier.stream import verify_streaming
            report = verify_streaming(args.block, model, args.model, args.data, args.inputs, args.engine,
                                      args.decimal, progress)
        if report is None:
            table = read_table(args.data, model.time_column, progress, args.decimal)
            if args.faults:
                from thermoplc.verifier.faults import format_cases, verify_faults
                from thermoplc.verifier.parser import parse_file
                from thermoplc.verifier.replay import subnormal_declarations
                cases = verify_faults(args.block, model, table, args.inputs, args.engine)
                print(format_cases(cases, args.block, table.rows))
                declared = subnormal_declarations(parse_file(args.block).decls, args.block)
                print("\n".join(f"UNSAFE: {line}" for line in declared))
                return 0 if all(c.ok for c in cases) and not declared else 1
            report = verify_against_model(args.block, model, args.model, table, args.inputs, args.engine)
    else:
        if args.faults:
            raise UserError("--faults needs --model: the faulty replay is compared with the model's reference")
        table = read_table(args.data, args.time, decimal=args.decimal)
        expect = {}
        for item in args.expect:
            output, sep, column = item.partition("=")
            output = output if sep else item
            if output.upper() in {k.upper() for k in expect}:
                raise UserError(f"--expect names output {output!r} twice; give each output one column")
            expect[output] = column if sep else item
        report = verify_against_trace(args.block, table, expect, args.inputs, args.time, args.engine)
    print(report.text())
    return 0 if report.ok else 1


def cmd_diff(args) -> int:
    from thermoplc.models.table import read_table
    from thermoplc.verifier.diff import diff_blocks, format_diff
    table = read_table(args.data, args.time, decimal=args.decimal) if args.data else None
    result = diff_blocks(args.old, args.new, table, args.inputs, args.time)
    print(format_diff(result))
    if table is not None and not result.behaviour_equal:
        return 1
    return 0 if result.structurally_equal else 1  # the data never excuses a structural change


def cmd_select(args) -> int:
    from thermoplc.models.fit import training_rows
    from thermoplc.models.leaks import (TEMPERATURE_RULE, leak_reason, refuse_leaks, refuse_non_temperatures,
                                        temperature_columns)
    from thermoplc.models.selection import select_sensors
    from thermoplc.models.table import read_table
    if args.output:
        check_output(args.output, args.force, inputs=[args.data])
    table = read_table(args.data, args.time, decimal=args.decimal)
    target = table.column(args.target)
    if args.candidates:
        candidates = args.candidates
        refuse_non_temperatures(table, candidates, "--candidates")
    else:
        candidates = temperature_columns(table.columns, (args.time, args.target))
        if not candidates:
            raise UserError(f"{args.data}: no temperature columns recognised ({TEMPERATURE_RULE.format(low=-40, high=150)}); "
                            f"name them with --candidates")
    if args.train_until is None and args.train_rows is None:
        rows = table.rows
    else:
        rows = training_rows(table, args.time, args.train_until, args.train_rows)
    skipped = {}
    if args.candidates:  # the user's list: a column that is the target in disguise is an error
        refuse_leaks({c: table.column(c)[:rows] for c in candidates}, args.target, target[:rows], args.data,
                     "--candidates")
    else:  # a recognised column that is the target in disguise is left out, with the reason
        skipped = {c: why for c in candidates if (why := leak_reason(c, table.column(c)[:rows], args.target, target[:rows]))}
        candidates = tuple(c for c in candidates if c not in skipped)
        if not candidates:
            raise UserError(f"{args.data}: every temperature column is the target in disguise: "
                            + "; ".join(f"{c} {why}" for c, why in skipped.items()))
    if rows < 3:
        raise UserError(f"{args.data}: {rows} rows; grouping sensors needs at least 3 of them")
    try:
        selection = select_sensors({c: table.column(c)[:rows] for c in candidates}, target[:rows],
                                   args.method, args.threshold, args.max_groups)
    except UserError as exc:
        raise UserError(str(exc) if str(exc).startswith(args.data) else f"{args.data}: {exc}") from None
    print(f"sensor selection ({selection.method}) for {args.target} on {Path(args.data).name}, {rows} rows")
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


def cmd_diagnose(args) -> int:
    from thermoplc.diagnosis.command import DiagnoseRequest, run
    from thermoplc.diagnosis.findings import text
    request = DiagnoseRequest(args.data, args.temps, args.speed, args.ambient, args.target, args.feed, args.baseline,
                              args.train_until, args.train_rows, args.time, args.name, args.decimal,
                              not args.no_structure_lag)
    if args.baseline and args.no_structure_lag:
        raise UserError("--no-structure-lag shapes a fitted baseline; with --baseline the model file decides")
    inputs = [p for p in (args.data, args.baseline) if p]
    files = [p for p in (args.output, args.json) if p]
    if len({Path(p).resolve() for p in files}) < len(files):
        raise UserError(f"{args.output}: named for two outputs; give each output its own file")
    for path in files:
        check_output(path, args.force, inputs=inputs)
    if args.report:
        from thermoplc.diagnosis.report import report_files
        owned = [*report_files(len(args.temps) + 1), REPORT_MANIFEST]
        for path in files:
            if Path(path).resolve().parent == Path(args.report).resolve() and Path(path).name in owned:
                raise UserError(f"{path}: is a file of the --report folder; give -o and --json names of their own")
        check_report_folder(args.report, owned[:-1], inputs=inputs)
    doc = run(request, args.output, args.json, args.report, _progress if sys.stderr.isatty() else None)
    if sys.stderr.isatty():
        print(file=sys.stderr)
    print(text(doc))
    print(f"wrote {args.output}" + (f", {args.json}" if args.json else "")
          + (f", {Path(args.report) / 'index.html'}" if args.report else ""))
    return 0


def cmd_demo(args) -> int:
    from thermoplc.demo import run_demo
    return run_demo(Path(args.out), args.force)


FORCE_HELP = "replace an existing output file (never an input of the command, never a non-regular file)"
DECIMAL = {"choices": ("auto", ".", ","), "default": "auto",
           "help": "decimal separator of the CSV: auto (',' when ';' separates the columns), '.' or ',' "
                   "(default: %(default)s)"}


def _training_part(parser: argparse.ArgumentParser, required: bool, default: str = ""):
    """The training part, in the same words for every command that has one."""
    part = parser.add_mutually_exclusive_group(required=required)
    tail = f" (default: {default})" if default else ""
    part.add_argument("--train-until", type=SECONDS, metavar="SECONDS", help=f"training part: rows with time <= SECONDS{tail}")
    part.add_argument("--train-rows", type=ROWS, metavar="N", help=f"training part: the first N rows{tail}")
    return part


class _Parser(argparse.ArgumentParser):
    """Command-line mistakes in one line, like every other error (the usage is one --help away)."""

    def error(self, message: str):
        self.exit(2, f"thermoplc: error: {message} (see {self.prog} --help)\n")


class _KindChoices:
    """`fit --model`'s choices, found when first asked: finding the kinds imports every model (numba
    included), which `--version`, `twin` or `diff` do not need."""

    def _all(self) -> tuple[str, ...]:
        from thermoplc.models.kinds import names
        return (*names(), "auto")

    def __contains__(self, value) -> bool:
        return value in self._all()

    def __iter__(self):
        return iter(self._all())


def build_parser() -> argparse.ArgumentParser:
    # the choices come from the packages: imported here, inside main's handling of Ctrl-C
    from thermoplc.machines import DEFAULT as DEFAULT_MACHINE, MACHINES as MACHINE_NAMES
    from thermoplc.models.bayes import UNSEEN_RULES
    from thermoplc.models.effects import NAMES as EFFECT_NAMES
    parser = _Parser(prog="thermoplc", description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--version", action="version", version=f"thermoplc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("demo", help="whole pipeline on the bundled FL_THERMAL recording")
    p.add_argument("--out", default="thermoplc-demo", help="output folder (default: %(default)s)")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("twin", help="synthetic machine data with known truth")
    p.add_argument("--machine", choices=MACHINE_NAMES, default=DEFAULT_MACHINE,
                   help="cascade: motor/bearing/ram/base network, run/stop at fixed speeds, daily sine ambient; "
                        "portal: three spindle-heated nodes and a lagging ram, random speeds, heated workshop "
                        "(default: %(default)s)")
    p.add_argument("--hours", type=_number(float, 1e-3, 1e6, "hours"), default=48.0,
                   help="length of the recording, h (default: %(default)s)")
    p.add_argument("--seed", type=SEED, default=0, help="random seed of the schedule and the noise (default: %(default)s)")
    p.add_argument("--dt", type=_number(float, 1e-3, 86400.0, "seconds"), default=10.0, help="sample period, s (default: %(default)s)")
    p.add_argument("--ambient-start", type=_number(float, -40.0, 60.0, "degC"), default=20.0, help="ambient temperature at the start, degC")
    p.add_argument("--ambient-swing", type=_number(float, 0.0, 30.0, "kelvin"), default=None,
                   help="day/night amplitude of the ambient, K (default: the machine's own, 0.5 cascade, 1 portal)")
    p.add_argument("--sensor-fault", action="append", default=[], metavar="KIND:COLUMN[@START_S]",
                   help="add paper 000's sensor error: sin (eq. 18) or offset (eq. 19); repeatable")
    p.add_argument("--effect", action="append", default=[], metavar="NAME[:KEY=VALUE,...]",
                   help=f"hide a physical effect in the data; repeatable. Names: {', '.join(EFFECT_NAMES)}")
    p.add_argument("--noise", type=_number(float, 0.0, 100.0, "a scale"), default=1.0, help="scale of the sensor noise (default: %(default)s)")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("-o", "--output", required=True, help="CSV file to write")
    p.set_defaults(func=cmd_twin)

    p = sub.add_parser("fit", help="fit a thermal-error model to a CSV file")
    p.add_argument("--data", required=True, action="append",
                   help="CSV file; repeat for piecewise (one file per batch, initial ambient read from each)")
    p.add_argument("--model", choices=_KindChoices(), metavar="KIND", required=True,
                   help="kalman (paper 000), lumped, mlr, dlag and piecewise (paper 001), bpnn (paper 002), gm0n and "
                        "gm1n (paper 003), bayes (paper 004); auto: every kind the given roles allow on sensor "
                        "sets from --temps (forward selection and fcm-grey), ranked by held-out RMSE, the best written")
    p.add_argument("--target", type=_columns, required=True,
                   help="measured displacement column, um; bpnn takes several: elongation,yaw,pitch")
    p.add_argument("--temps", type=_columns, required=True,
                   help="temperature columns, comma-separated, or @FILE written by select-sensors -o")
    p.add_argument("--speed", help="spindle speed column, rpm (kalman)")
    p.add_argument("--ambient", help="ambient temperature column, degC (kalman, piecewise)")
    p.add_argument("--time", default="time_s", help="time column, s (default: %(default)s)")
    _training_part(p, required=True).add_argument(
        "--folds", type=_number(int, 2, 20, "blocks"), metavar="K",
        help="fit on every row, with held-out evidence from blocked cross-validation: K contiguous blocks (cut at "
             "standstills when --speed is given), each predicted by a fit on the blocks before it; with several "
             "--data files, each file predicted by a fit on the others")
    p.add_argument("--optimizer", choices=("ga", "de"), default="ga",
                   help="ga: paper 000's genetic algorithm; de: scipy differential evolution")
    p.add_argument("--seed", type=SEED, default=0, help="random seed of the optimiser (default: %(default)s)")
    p.add_argument("--generations", type=_number(int, 1, 10000, "generations"), default=60,
                   help="generations of the GA or DE (default: %(default)s)")
    p.add_argument("--population", type=_number(int, 2, 10000, "individuals"), default=40,
                   help="individuals per generation (default: %(default)s)")
    p.add_argument("--ga-operators", choices=("paper002", "paper000"), default="paper002",
                   help="bpnn: the GA's crossover and mutation, paper 002's single-point crossover and one mutated "
                        "position, or paper 000's arithmetic crossover and Gaussian mutation (default: %(default)s; "
                        "benchmarks/ga_operators.py compares them held out)")
    p.add_argument("--jump-limit", type=_number(float, 1e-6, 1e3, "kelvin"), help="K per call that marks a sensor faulty (default from data)")
    p.add_argument("--recover-limit", type=_number(float, 1e-6, 1e3, "kelvin"), help="K between measurement and model to recover (default from data)")
    p.add_argument("--bins", type=_number(int, 1, 4096, "intervals"), default=8, help="bayes: intervals per temperature (default: %(default)s)")
    p.add_argument("--precision-um", type=_number(float, 1e-3, 1e6, "micrometres"), default=1.0,
                   help="bayes: interval width of the error, the precision requirement (default: %(default)s)")
    p.add_argument("--unseen", choices=UNSEEN_RULES, default=UNSEEN_RULES[0],
                   help="bayes: a temperature configuration never seen in training answers as the nearest seen one, "
                        "or the error interval most frequent overall (default: %(default)s)")
    p.add_argument("--time-bins", type=_number(int, 0, 4096, "intervals"), default=0, metavar="N",
                   help="bayes: the time since the first call is a parent too, in N intervals (paper 004's repeated "
                        "runs: give one --data file per run; default: %(default)s, no time parent)")
    p.add_argument("--lags", type=_number(int, 1, 1000, "lags"), default=3, help="dlag: lagged terms per sensor (default: %(default)s)")
    p.add_argument("--lag-step", type=_number(float, 1e-3, 1e7, "seconds"), default=600.0, metavar="SECONDS",
                   help="dlag: time between lags (default: %(default)s)")
    p.add_argument("--tool-length", metavar="COLUMN",
                   help="bpnn: tool length column, mm; adds paper 002's X/Y/Z compensation outputs")
    p.add_argument("--name", default="ThermalComp",
                   help="function block name, kept in the model file (generate --name overrides it) (default: %(default)s)")
    p.add_argument("--decimal", **DECIMAL)
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("-o", "--output", required=True, help="model file to write (JSON)")
    p.set_defaults(func=cmd_fit)

    p = sub.add_parser("select-sensors", help="group similar temperature sensors and choose one per group")
    p.add_argument("--data", required=True, help="CSV file (or .npz of columns)")
    p.add_argument("--target", required=True, help="measured displacement column, um")
    p.add_argument("--method", choices=("fcm-grey", "grey-cluster"), default="fcm-grey",
                   help="fcm-grey: paper 001's fuzzy clustering + grey relational grade; "
                        "grey-cluster: paper 002's grey clustering + correlation")
    p.add_argument("--candidates", type=_columns,
                   help="temperature columns to choose from (default: the columns named like temperatures - T_..., "
                        "T1, ...temp..., ..._C - whose values all lie in -40..150 degC)")
    p.add_argument("--threshold", type=_number(float, 0.0, 1.0, "a degree"), default=0.9,
                   help="grey-cluster: comprehensive degree that joins two sensors (paper 002: %(default)s)")
    p.add_argument("--max-groups", type=_number(int, 1, 1000, "groups"), default=5, help="fcm-grey: at most this many groups (default: %(default)s)")
    _training_part(p, required=False, default="all rows")
    p.add_argument("--time", default="time_s", help="time column, s (default: %(default)s)")
    p.add_argument("-o", "--output", help="write the chosen sensors for fit --temps @FILE")
    p.add_argument("--decimal", **DECIMAL)
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(func=cmd_select)

    p = sub.add_parser("diagnose", help="find the physical effect the lumped-mass simulation misses")
    p.add_argument("--data", required=True, help="measured CSV")
    p.add_argument("--temps", type=_columns, required=True, help="temperature columns, comma-separated")
    p.add_argument("--speed", required=True, help="spindle speed column, rpm")
    p.add_argument("--ambient", required=True, help="ambient temperature column, degC")
    p.add_argument("--target", required=True, help="measured displacement column, um")
    p.add_argument("--feed", help="feed-axis rate column, mm/min (enables the feed_axis_heat candidate)")
    p.add_argument("--baseline", help="a lumped model file written by diagnose to start from instead of fitting the baseline")
    p.add_argument("--no-structure-lag", action="store_true",
                   help="baseline displacement from the simulated temperatures alone (paper 000 eq. 10), without "
                        "the structure that lags them")
    _training_part(p, required=False, default="the first 60%% of the rows")
    p.add_argument("--time", default="time_s", help="time column, s (default: %(default)s)")
    p.add_argument("--name", default="ThermalComp", help="function block name of the augmented model")
    p.add_argument("--decimal", **DECIMAL)
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("--json", help="write the findings here (findings.json)")
    p.add_argument("--report", metavar="FOLDER", help="write an HTML report with plots into this folder")
    p.add_argument("-o", "--output", default="diagnosed_model.json",
                   help="augmented model file (default: %(default)s)")
    p.set_defaults(func=cmd_diagnose)

    p = sub.add_parser("generate", help="compile a model file into a Structured Text function block")
    p.add_argument("model", help="model file written by fit or diagnose")
    p.add_argument("--dialect", choices=("tia", "step7", "iec"), default="tia",
                   help="tia: S7-1500/SINUMERIK ONE (TIA Portal); step7: classic STEP 7 SCL (840D sl, S7-300); "
                        "iec: IEC 61131-3 for CODESYS/TwinCAT/OpenPLC (default: %(default)s)")
    p.add_argument("--format", choices=("st", "plcopen"), default="st",
                   help="st: source text; plcopen: PLCopen TC6 XML of the iec block (default: %(default)s)")
    p.add_argument("--max-offset-um", type=_number(float, 1e-6, 1e12, "micrometres"), default=300.0,
                   help="clamp every output to +-this (um; urad for angles) (default: %(default)s)")
    p.add_argument("--max-step-um", type=_number(float, 1e-6, 1e12, "micrometres"), default=2.0,
                   help="largest change of an output per call (default: %(default)s)")
    p.add_argument("--temp-range", type=_range, default=(-40.0, 150.0), metavar="LOW,HIGH",
                   help="plausible temperatures, degC; outside = sensor fault (default: -40,150)")
    p.add_argument("--max-jump-k", type=_number(float, 1e-6, 1e6, "kelvin"), default=1.0,
                   help="temperature change per call that marks a sensor faulty, K (default: %(default)s)")
    p.add_argument("--settle-calls", type=_number(int, 1, 10000, "calls"), default=30,
                   help="steady calls before a faulty sensor is trusted again (default: %(default)s)")
    p.add_argument("--name", help="function block name (default: the model file's, set by fit --name); one block "
                                  "per axis needs one name each")
    p.add_argument("--retain", action="store_true",
                   help="keep the state over a power cycle: statics and outputs declared RETAIN (tia, iec); step7: "
                        "the header says to keep the instance DB retentive")
    p.add_argument("--instance-db", metavar="NAME",
                   help="step7: append the source of an instance DB NAME of the block (enter NAME in the symbol table)")
    p.add_argument("--author", type=_attribute, default="thermopl",
                   help="AUTHOR in the block header, at most 8 letters, digits or '_' (default: %(default)s)")
    p.add_argument("--family", type=_attribute, default="ThermCmp",
                   help="FAMILY in the block header, at most 8 letters, digits or '_' (default: %(default)s)")
    p.add_argument("--block-version", type=_block_version, metavar="X.Y",
                   help="VERSION in the block header, each part 0 to 15 (default: the first two hex digits of the "
                        "model fingerprint, so a changed model changes the version)")
    p.add_argument("--date", type=_date, metavar="YYYY-MM-DD",
                   help="date in the header comment (default: today, or SOURCE_DATE_EPOCH when set)")
    p.add_argument("--stats", action="store_true", help="print operations per call and bytes of state")
    p.add_argument("--accept-unvalidated", action="store_true",
                   help="write the block although the model file has no held-out evidence that it beats no "
                        "compensation (or has evidence that it does not); the header says so")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("--explain", action="store_true", help="print which region computes which model term, "
                                                          "with its constants")
    p.add_argument("-o", "--output", required=True, help="source file to write (.scl, .st or .xml)")
    p.set_defaults(func=cmd_generate)

    p = sub.add_parser("diff", help="what changed between two blocks: constants, interface, statements, behaviour")
    p.add_argument("old", help="the block as it was (ST source)")
    p.add_argument("new", help="the block as it is now (ST source)")
    p.add_argument("--data", help="replay both blocks on this CSV and report the largest output difference")
    p.add_argument("--decimal", **DECIMAL)
    p.add_argument("--inputs", type=_mapping, help="block input to column mapping NAME=COLUMN,...")
    p.add_argument("--time", default="time_s", help="time column (default: %(default)s)")
    p.set_defaults(func=cmd_diff)

    p = sub.add_parser("verify", help="replay data through a block and compare every output bit for bit")
    p.add_argument("block", nargs="?", help="the block's ST source")
    p.add_argument("--data", help="the recording (CSV, .npz or Parquet of columns), one row per call; columns "
                                   "Enable and Reset (0/1), when present, drive those block inputs")
    p.add_argument("--decimal", **DECIMAL)
    p.add_argument("--model", help="compare with this model's float32 reference")
    p.add_argument("--expect", type=_columns, help="compare with recorded outputs: COLUMN or OUTPUT=COLUMN, comma-separated")
    p.add_argument("--inputs", type=_mapping, help="block input to column mapping NAME=COLUMN,...")
    p.add_argument("--manifest", help="CSV of pairs to verify (columns block,data and model or expect, optional inputs)")
    p.add_argument("--jobs", type=_number(int, 1, 256, "processes"), default=1, help="with --manifest: pairs verified in parallel (default: %(default)s)")
    p.add_argument("--engine", choices=("auto", "interp", "fast"), default="auto",
                   help="interp: the reference interpreter; fast: the block compiled to C (same bits); "
                        "auto: fast when a C compiler is there (default: %(default)s)")
    p.add_argument("--faults", action="store_true",
                   help="replay with injected sensor faults (NaN, open/short PT100, jumps, paper 000 sine and "
                        "offset) and check exactness, finiteness, clamp and rate limit")
    p.add_argument("--time", default="time_s", help="time column for --expect traces (default: %(default)s)")
    p.set_defaults(func=cmd_verify)
    return parser


class Terminated(BaseException):
    """SIGTERM, raised where the program is so that temporary files are removed on the way out."""


def _terminate(signum, frame):
    raise Terminated()


def main(argv: list[str] | None = None) -> int:
    signal.signal(signal.SIGTERM, _terminate)
    try:
        return _run(argv)
    finally:
        try:
            sys.stdout.flush()
        except OSError:  # stdout is a full disk or a closed pipe: nothing more can be said there
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


def _named_inputs(args) -> str:
    """The files a command read, for a message that cannot say which one was at fault."""
    for keys in (("block",), ("old", "new"), ("model",), ("manifest",)):  # the ST source first: it is what nests
        names = [getattr(args, key, None) for key in keys]
        if all(isinstance(n, str) for n in names):
            return ", ".join(names)
    return "an input"


def _run(argv: list[str] | None) -> int:
    args = None
    try:
        args = build_parser().parse_args(argv)
        return args.func(args)
    except UserError as exc:
        print(f"thermoplc: error: {exc}", file=sys.stderr)
        return 2
    except RecursionError:  # an expression or statement nesting deeper than Python's stack (thousands of levels)
        print(f"thermoplc: error: {_named_inputs(args)}: expressions or statements nested too deeply to read "
              f"(thousands of levels); nothing written", file=sys.stderr)
        return 2
    except MemoryError:
        print("thermoplc: error: an input needs more memory than this machine has (a huge array or table?); "
              "nothing written", file=sys.stderr)
        return 2
    except BrokenPipeError:  # the reader left (`| head`): stop quietly with the shell's SIGPIPE status
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except KeyboardInterrupt:
        print("thermoplc: interrupted; nothing half-written left behind", file=sys.stderr)
        return 130
    except Terminated:
        print("thermoplc: terminated; nothing half-written left behind", file=sys.stderr)
        return 143
    except OSError as exc:  # writing the answer failed: stdout on a full disk, say
        if exc.errno == errno.EPIPE:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 141
        print(f"thermoplc: error: {exc.filename or 'standard output'}: {exc.strerror or exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
