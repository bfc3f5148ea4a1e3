"""`thermoplc fit`: a model file from one or more recordings (thermoplc.fitting: fit, held-out evidence)."""
from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from thermoplc.base.errors import UserError
from thermoplc.base.fileio import check_outputs, write_outputs
from thermoplc.commands import json_output
from thermoplc.commands.fit_options import Given, refuse_columns_not_read, refuse_options_not_read
from thermoplc.commands.options import (EVERY_HELP, FORCE_HELP, OUTPUT, RESAMPLE, campaign_arguments, columns,
                                        every, examples, named, number, reading_arguments, reading_of,
                                        scheduler_address, training_part)
from thermoplc.commands.reads import Writes, files_read
from thermoplc.commands.terminal import end_progress, progress
from thermoplc.recordings.formats import described


def add_parser(sub) -> None:
    from thermoplc.models.kinds import names  # the kinds' records build the options below too
    p = sub.add_parser(
        "fit", help="fit a thermal-error model to a recording or a campaign of runs",
        description="Fit a thermal-error model to a recording or a campaign of runs\n"
                    f"({described()}) and judge it on rows it never saw; `thermoplc generate`\n"
                    "compiles the model file into a PLC block.",
        **examples("docs/models.md (the kinds and their papers), docs/campaigns.md (runs, probed targets, --resample)",
                   "thermoplc fit --data fl_thermal.csv --model dlag --target ch3_um --temps t8_C,t4_C,t5_C,t11_C \\",
                   "    --train-until 86400 -o model.json",
                   "thermoplc fit --data runs --model mlr --target E_z_um --held-target --temps T_motor,T_bearing \\",
                   "    --folds 8 --probe --report report -o fused.json",
                   "thermoplc fit --data logger_files --resample 40 --model auto --target disp_x_um \\",
                   "    --temps @sensors.txt --speed rpm --ambient hall_C --folds 10 -o auto.json"))
    p.register("action", None, Given)  # every plain option notes that it was given (fit_options.py)
    p.set_defaults(given=())
    data = p.add_argument_group("data")
    model = p.add_argument_group("model")
    evaluation = p.add_argument_group("training part and held-out evidence")
    probing = p.add_argument_group("probe fusion (docs/probing.md)")
    kinds = _kind_groups(p)
    output = p.add_argument_group("output")
    campaign_arguments(data, "each started as a fresh block (piecewise: one run per batch, its initial ambient read "
                          "from each)", " and free attribute columns (hall air setpoint, programme, date, ...)")
    model.add_argument("--model", choices=(*names(), "auto"), metavar="KIND", required=True,
                       help=f"{_by_paper()}; auto: every kind the given roles allow on sensor sets from --temps "
                            "(forward selection and fcm-grey), ranked by held-out RMSE, the best written")
    model.add_argument("--target", type=columns, required=True,
                       help=f"measured displacement column, um; {_reading('extra_targets')} takes several: "
                            "elongation,yaw,pitch. A probed target may be empty between probings: the fit and every "
                            "error use the measured rows, the temperatures every row")
    model.add_argument("--temps", type=columns, required=True,
                       help="temperature columns, comma-separated, or @FILE written by select-sensors -o; with "
                            "--choose-sensors the candidates")
    model.add_argument("--choose-sensors", type=number(int, 1, 64, "sensors"), metavar="N", default=0,
                       help="choose at most N of --temps on the training rows (forward selection, each run left out "
                            "or the last third; every fold chooses again; on the first --target): the block reads the "
                            "chosen ones")
    model.add_argument("--speed", help=f"spindle speed column, rpm ({_with_role('speed')}; auto tries them only with it)")
    model.add_argument("--ambient", help=f"ambient temperature column, degC ({_with_role('ambient')})")
    data.add_argument("--time", default="time_s", help="time column, s (default: %(default)s)")
    part = training_part(evaluation, required=True)
    part.add_argument(
        "--folds", type=number(int, 2, 1_000_000, "folds"), metavar="K",
        help="fit on every row, with held-out evidence from cross-validation. One recording: K (2 to 20) contiguous "
             "blocks (cut at standstills when --speed is given), each predicted by a fit on the blocks before it. "
             "Several runs: K folds of whole runs, each run predicted from its first row by a fit on the other runs "
             "(K = the number of runs: leave one run out)")
    part.add_argument("--group-by", metavar="COLUMN", type=named("a column of the runs table"),
                      help="fit on every row, with held-out evidence from leave-one-group-out cross-validation over "
                           "the groups of this column of the --runs table (fit on the cool days, predict the warm "
                           "ones)")
    evaluation.add_argument("--keep-every-run", action="store_true",
                            help="train on every run of a campaign: a run whose sensors disagree with the other runs' "
                                 "and that a fit on the others predicts far worse than them is otherwise refused for "
                                 "training, named, and reported apart (docs/campaigns.md)")
    data.add_argument("--held-target", action="store_true",
                      help="the target holds its last probing between probings: only the first row and the rows where "
                           "it changes are measurements (an empty target cell is always a row without a measurement)")
    probing.add_argument("--probe", action="store_true",
                         help="a fused block: the block also takes the machine's probings (ProbeValue, ProbeNew) and moves "
                              "its prediction by an offset each probing teaches; gain, drift rate, decay and gate chosen on "
                              "held-out runs (--folds or --group-by on a campaign, or the held-out part of one recording)")
    probing.add_argument("--probe-gate-um", type=number(float, 0.1, 1e5, "um"), metavar="UM",
                         help="with --probe: refuse a probing further than UM from the prediction (one in a row; the "
                              "second beyond it is taken: the drift moved). Default: 4 x the RMS of the held-out "
                              "innovations, at least 2 x the largest of them, at least 0.5 um (docs/probing.md)")
    probing.add_argument("--probe-every", type=every, metavar="WHEN",
                         help=f"with --probe on a target measured at every call: simulate a probing every {EVERY_HELP} "
                              "(a probed target's own measured rows are its probings)")
    output.add_argument("--report", metavar="DIR", type=Writes(named("a folder for the report")),
                        help="also write a report folder: per run measured, predicted and no compensation, the residual, "
                             "the fold and group tables, one PNG per run and an index.html")
    evaluation.add_argument("--scheduler", metavar="ADDRESS", type=scheduler_address,
                            help="with --folds or --group-by: fit the folds as tasks of the Dask distributed cluster whose "
                                 "scheduler is at ADDRESS (tcp://HOST:PORT; the fleet extra) while this process fits on every "
                                 "row; every worker reads the runs by the paths given. The same model file, bit for bit")
    _kind_options(kinds)
    model.add_argument("--name", default="ThermalComp",
                       help="function block name, kept in the model file (generate --name overrides it) (default: %(default)s)")
    reading_arguments(data)
    data.add_argument("--resample", **RESAMPLE)
    output.add_argument("--force", action="store_true", help=FORCE_HELP)
    output.add_argument("-o", "--output", required=True, type=OUTPUT, help="model file to write (JSON)")
    json_output.add_arguments(output, force=False)
    p.set_defaults(func=run)


def _by_paper() -> str:
    """The kinds by the paper each comes from, as their records say."""
    from thermoplc.models.kinds import registry
    papers: dict[str, list[str]] = {}
    for kind in registry().values():
        papers.setdefault(kind.paper, []).append(kind.name)
    return "; ".join(f"paper {paper}: {', '.join(names)}" for paper, names in sorted(papers.items()))


def _with_role(role: str) -> str:
    from thermoplc.models.kinds import registry
    return ", ".join(kind.name for kind in registry().values() if role in kind.roles)


def _reading(field: str) -> str:
    from thermoplc.models.kinds import readers
    return " and ".join(kind.name for kind in readers(field))


def _kind_groups(p: argparse.ArgumentParser) -> dict[str, argparse._ArgumentGroup]:
    """Each kind option's help group (models/kind.py::KindOption): one per set of kinds that read the same options."""
    from thermoplc.models.kinds import options, readers
    groups: dict[tuple[str, ...], argparse._ArgumentGroup] = {}
    by_field = {}
    for field in options():
        names = tuple(kind.name for kind in readers(field))
        if names not in groups:
            groups[names] = p.add_argument_group(f"{' and '.join(names)} only (refused for any other kind)")
        by_field[field] = groups[names]
    return by_field


def _kind_options(groups: dict[str, argparse._ArgumentGroup]) -> None:
    """Each kind's own options as its record declares them: flag, default, help and the check of its value;
    each is refused for a kind that does not read it (fit_options.py)."""
    from thermoplc.models.kinds import options
    for option in options().values():
        parse = number(*option.number) if option.number else None
        groups[option.field].add_argument(option.flag, dest=option.field, default=option.default, help=option.help,
                                          **({"type": parse} if parse else {}),
                                          **({"choices": option.choices} if option.choices else {}),
                                          **({"metavar": option.metavar} if option.metavar else {}))


def resampling_of(args: argparse.Namespace):
    """--resample as the rule the model file records: the speed column held at its last value."""
    from thermoplc.recordings.resample import Resampling
    return Resampling.holding(args.resample, (args.speed,))


def _remote(args: argparse.Namespace, campaign, runs):
    """The cluster the folds run on (--scheduler), each fold reading the runs where it runs; None: here."""
    if not args.scheduler:
        return None
    from thermoplc.base.cluster import connect
    from thermoplc.recordings.campaign import source_of
    from thermoplc.fitting.crossval import Remote
    source = source_of(campaign, runs, args.time, reading_of(args), tuple(args.target), args.held_target,
                       resampling_of(args))
    return Remote(connect(args.scheduler), source)


def run(args: argparse.Namespace) -> int:
    from thermoplc.commands.fit_auto import print_ranking
    from dataclasses import replace
    from thermoplc.fit_pipeline import FitPlan, fit, request_problem, runs_problem
    from thermoplc.commands.fit_summary import fit_document, format_fit
    from thermoplc.fitting.acceptance import refusal
    from thermoplc.fitting.fit import FitRequest, common_sample_period
    from thermoplc.models.kinds import options
    from thermoplc.recordings.campaign import read_campaign, run_list
    from thermoplc.recordings.table import reading_notes
    from thermoplc.commands.fit_report import INDEX, is_report_file, report_files, report_names
    request = FitRequest(kind=args.model, target=args.target[0], temps=args.temps, speed=args.speed,
                         ambient=args.ambient, train_until=args.train_until, train_rows=args.train_rows,
                         block_name=args.name, extra_targets=args.target[1:], choose_sensors=args.choose_sensors,
                         settings={field: getattr(args, field) for field in options()},
                         keep_every_run=args.keep_every_run)
    # the plan's options as the library takes them, checked before any run is read (the groups once they are):
    # the kind's first, then the cluster's, then the fusion's
    asked = FitPlan(args.folds, {} if args.group_by else None, args.probe, None, None, args.held_target, args.resample)
    if problem := request_problem(request, asked):
        raise UserError(problem)
    if args.scheduler and not (args.folds or args.group_by):
        raise UserError("--scheduler runs the folds of --folds or --group-by on a cluster; give one of them")
    asked = replace(asked, probe_gate_um=args.probe_gate_um)
    if problem := request_problem(request, replace(asked, probe_every=1 if args.probe_every else None)):
        raise UserError(problem)
    refuse_options_not_read(args, request)
    runs = run_list(args.data, args.runs)
    if problem := runs_problem(request, asked, len(runs.paths)):
        raise UserError(problem)
    stale = check_outputs({"-o": args.output, "--json": json_output.file(args)}, args.force, files_read(args), args.report,
                          report_names(list(runs.paths)), is_report_file)
    campaign = read_campaign(runs, args.time, reading_of(args), probed=args.target, held=args.held_target,
                             resampling=resampling_of(args))
    groups = campaign.groups(args.group_by) if args.group_by else None
    tables = campaign.tables
    every = args.probe_every.calls_at(common_sample_period(tables, args.time)) if args.probe_every else None
    refuse_columns_not_read(args, request, tables)
    remote = _remote(args, campaign, runs)
    plan = replace(asked, groups=groups, probe_every=every)
    try:
        fitted = fit(tables, request, args.time, plan, progress(), remote, args.output)
    finally:
        end_progress()  # a refusal from any stage of the fit on a line of its own
        if remote is not None:
            remote.cluster.close()
    if args.model == "auto":
        print_ranking(fitted, request, plan.probing, len(tables) > 1 or groups is not None)
    model, predictions = fitted.model, fitted.predictions
    document = fit_document(model, args.output)
    command = " ".join(shlex.quote(a) for a in ("thermoplc", *sys.argv[1:]))
    refused = refusal(model)
    outputs = [*(report_files(args.report, model, campaign, predictions, command, refused)
                 if args.report is not None else []),
               (args.output, model.to_json()),
               *([(json_output.file(args), json_output.encoded(document))] if json_output.file(args) else [])]
    write_outputs(outputs, remove=[Path(args.report) / name for name in stale])  # all of them, or none
    report = Path(args.report) / INDEX if args.report is not None else None
    text = f"{format_fit(model, campaign)}\nwrote {args.output}" + (f"\nwrote {report}" if report else "")
    for note in reading_notes(tables):  # once the fit stands: a refusal stays one line
        print(note, file=sys.stderr)
    json_output.emit(args, text, document, written=True)
    if refused:
        print(f"thermoplc: WARNING: generate will refuse this model: {refused}", file=sys.stderr)
    return 0
