"""`thermoplc twin`: synthetic machine data with known truth (thermoplc.machines)."""
from __future__ import annotations

import argparse

from thermoplc.base.errors import UserError
from thermoplc.base.fileio import check_output, write_atomic
from thermoplc.commands.options import EVERY_HELP, FORCE_HELP, OUTPUT, SEED, every, examples, number

MAX_TWIN_ROWS = 50_000_000  # about 1.6 years at 1 s, over all runs; beyond it the files alone take several GB


def add_parser(sub) -> None:
    # the choices come from the packages: imported here, inside main's handling of Ctrl-C
    from thermoplc.machines import DEFAULT as DEFAULT_MACHINE, MACHINES as MACHINE_NAMES
    from thermoplc.physics.effects import NAMES as EFFECT_NAMES
    p = sub.add_parser("twin", help="synthetic machine data with known truth",
                       **examples("README.md and docs/campaigns.md",
                                  "thermoplc twin --hours 48 --seed 3 -o twin.csv",
                                  "thermoplc twin --runs 8 --hours 8 --dt 60 --probe-minutes 30 -o runs",
                                  "thermoplc twin --runs 6 --hours 6 --dt 40 --probe-minutes 30 --logger -o raw"))
    p.add_argument("--machine", choices=MACHINE_NAMES, default=DEFAULT_MACHINE,
                   help="cascade: motor/bearing/ram/base network, run/stop at fixed speeds, daily sine ambient; "
                        "portal: three spindle-heated nodes and a lagging ram, random speeds, heated workshop "
                        "(default: %(default)s)")
    p.add_argument("--hours", type=number(float, 1e-3, 1e6, "hours"), default=48.0,
                   help="length of the recording, h (default: %(default)s)")
    p.add_argument("--seed", type=SEED, default=0, help="random seed of the schedule and the noise (default: %(default)s)")
    p.add_argument("--dt", type=number(float, 1e-3, 86400.0, "seconds"), default=10.0, help="sample period, s (default: %(default)s)")
    p.add_argument("--ambient-start", type=number(float, -40.0, 60.0, "degC"),
                   help="ambient temperature at the start, degC (default: 20; a campaign sets each run's own)")
    p.add_argument("--ambient-swing", type=number(float, 0.0, 30.0, "kelvin"), default=None,
                   help="day/night amplitude of the ambient, K (default: the machine's own, 0.5 cascade, 1 portal)")
    p.add_argument("--sensor-fault", action="append", default=[], metavar="KIND:COLUMN[@START_S]",
                   help="add paper 000's sensor error: sin (eq. 18) or offset (eq. 19); repeatable")
    p.add_argument("--effect", action="append", default=[], metavar="NAME[:KEY=VALUE,...]",
                   help=f"hide a physical effect in the data; repeatable. Names: {', '.join(EFFECT_NAMES)}")
    p.add_argument("--noise", type=number(float, 0.0, 100.0, "a scale"), default=1.0, help="scale of the sensor noise (default: %(default)s)")
    p.add_argument("--runs", type=number(int, 1, 10000, "runs"), metavar="N",
                   help="a campaign: N runs of --hours each of the same machine (hall air held at levels from 14 to "
                        "34 degC or swinging, or stepped to --ambient-levels; cold and warm starts, the seed's speed "
                        "programmes), written into the folder -o with a runs table runs.csv")
    p.add_argument("--probe-minutes", type=number(float, 0.0, 1e6, "minutes"), default=0.0, metavar="M",
                   help="with --runs: the drift E_z_um probed every M minutes and held between probings, relative "
                        "to the run's first probing (E_z_true_um beside it); 0: every call (default: %(default)s)")
    p.add_argument("--probe-every", type=every, metavar="WHEN",
                   help=f"with --runs: --probe-minutes in the spelling of fit, verify and diff: every {EVERY_HELP} "
                        f"(calls of --dt)")
    p.add_argument("--ambient-levels", type=_levels, metavar="C,C,...",
                   help="with --runs: a designed ambient experiment: the machine soaks at 20 degC, and as each run "
                        "starts the hall air moves to the next of these levels (degC, taken in turn) and is held")
    p.add_argument("--effect-runs", type=_run_numbers, metavar="K,K,...",
                   help="with --runs: hide the --effect only in these runs (numbered from 1; default: every run)")
    p.add_argument("--logger", action="store_true",
                   help="write each file as a raw data logger does: every --dt/4 s for the first 16 min, then every "
                        "--dt s, each time stamp off by up to 1 s (fit it with --resample DT)")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.add_argument("-o", "--output", required=True, type=OUTPUT, help="CSV file to write (with --runs: a new or empty folder)")
    p.set_defaults(func=run)


def _run_numbers(text: str) -> tuple[int, ...]:
    try:
        numbers = tuple(int(k) for k in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected run numbers K,K,... (from 1), found {text!r}") from None
    if not numbers or min(numbers) < 1:
        raise argparse.ArgumentTypeError(f"expected run numbers K,K,... (from 1), found {text!r}")
    return numbers


def _levels(text: str) -> tuple[float, ...]:
    try:
        levels = tuple(float(k) + 0.0 for k in text.split(","))  # -0 is the level 0
    except ValueError:
        levels = ()
    if not levels or not all(-40.0 <= level <= 60.0 for level in levels):  # NaN fails the range too
        raise argparse.ArgumentTypeError(f"expected hall air levels C,C,... in degC from -40 to 60, found {text!r}")
    return levels


def run(args: argparse.Namespace) -> int:
    from thermoplc.machines import machine
    from thermoplc.machines.faults import SensorFault
    from thermoplc.recordings.table import write_table
    from thermoplc.physics.effects import Effect
    chosen = machine(args.machine)
    runs = args.runs or 1
    if runs * args.hours * 3600 / args.dt > MAX_TWIN_ROWS:  # each option is checked by its type; their product here
        given = f"--runs {runs} of " if args.runs else ""
        raise UserError(f"{given}--hours {args.hours:g} at --dt {args.dt:g} gives more than {MAX_TWIN_ROWS:,} rows in "
                        f"all; use a longer --dt, fewer hours{' or fewer runs' if args.runs else ''}")
    faults = tuple(SensorFault.parse(f, chosen.SENSORS) for f in args.sensor_fault)
    effects = tuple(Effect.parse(e, chosen.COLUMN_DEFAULTS) for e in args.effect)
    names = [e.name for e in effects]
    if len(set(names)) != len(names):
        raise UserError("--effect: each effect can be switched on once")
    if args.probe_every is not None:
        if args.probe_minutes:
            raise UserError("--probe-every and --probe-minutes say the same; give one of them")
        args.probe_minutes = args.probe_every.calls_at(args.dt) * args.dt / 60
    if args.runs is None:
        if args.probe_minutes or args.effect_runs or args.ambient_levels:
            raise UserError("--probe-every (--probe-minutes), --effect-runs and --ambient-levels describe a campaign: "
                            "give --runs N")
    else:
        if faults:
            raise UserError("--sensor-fault: not with --runs (a campaign's runs are clean of sensor faults)")
        if args.ambient_start is not None or args.ambient_swing is not None:
            raise UserError("--ambient-start and --ambient-swing: not with --runs (each run has its own hall air, "
                            "held at a level from 14 to 34 degC, swinging by 3 K, or stepped to --ambient-levels; "
                            "runs.csv says which)")
        if args.ambient_levels and len(args.ambient_levels) > args.runs:
            raise UserError(f"--ambient-levels gives {len(args.ambient_levels)} levels for --runs {args.runs}: each "
                            f"level needs a run (they are taken in turn)")
        if args.effect_runs and not effects:
            raise UserError("--effect-runs says in which runs the --effect hides; give --effect NAME")
        if args.effect_runs and len(set(args.effect_runs)) != len(args.effect_runs):
            raise UserError(f"--effect-runs {','.join(map(str, args.effect_runs))}: a run is named twice")
        step = args.probe_minutes * 60 / args.dt
        if args.probe_minutes and (step < 1 or abs(step - round(step)) > 1e-9):
            raise UserError(f"--probe-minutes {args.probe_minutes:g}: a probing falls on a call, so a whole number of "
                            f"--dt {args.dt:g} s periods (at least {args.dt / 60:g} min)")
        if args.probe_minutes and args.probe_minutes * 60 * 2 > args.hours * 3600:
            raise UserError(f"--probe-minutes {args.probe_minutes:g}: fewer than 3 probings in a run of "
                            f"{args.hours:g} h; a fit needs several per run")
        return _campaign(args, effects)
    check_output(args.output, args.force)
    options = {} if args.ambient_swing is None else {"ambient_swing": args.ambient_swing}
    columns = chosen.simulate(args.hours, args.seed, _simulated_period(args),
                              20.0 if args.ambient_start is None else args.ambient_start,
                              faults=faults, effects=effects, noise=args.noise, **options)
    columns = _as_written(args, columns, args.seed)
    write_atomic(args.output, write_table(columns))
    rows = len(columns["time_s"])
    print(f"wrote {args.output}: {rows} rows, {args.hours:g} h {_pace(args)}, seed {args.seed}, "
          f"machine {chosen.NAME}")
    for e in effects:
        print(f"  hidden effect {e.name}: " + ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                                     for k, v in e.parameters))
    for fault in faults:
        print(f"  {fault.describe()}")
    print(f"  columns: {', '.join(columns)}")
    return 0


def _simulated_period(args: argparse.Namespace) -> float:
    from thermoplc.machines.logger import fast_period
    return fast_period(args.dt) if args.logger else args.dt


def _as_written(args: argparse.Namespace, columns: dict, seed: int) -> dict:
    from thermoplc.machines.logger import logged
    return logged(columns, args.dt, seed) if args.logger else columns


def _pace(args: argparse.Namespace) -> str:
    from thermoplc.machines.logger import FAST_MINUTES, JITTER_S, fast_period
    if not args.logger:
        return f"every {args.dt:g} s"
    minutes = min(FAST_MINUTES, args.hours * 60)
    then = f", then {args.dt:g} s" if args.hours * 60 > FAST_MINUTES else ""
    return (f"as a data logger writes them (every {fast_period(args.dt):g} s for {minutes:g} min{then}, "
            f"{min(JITTER_S, 0.45 * fast_period(args.dt)):g} s of jitter)")


def _campaign(args: argparse.Namespace, effects: tuple) -> int:
    """`twin --runs N`: the runs and their runs table into a folder, all files or none."""
    from pathlib import Path
    from thermoplc.base.fileio import write_outputs
    from thermoplc.machines.campaign import plan, simulate_run
    from thermoplc.machines.hall import REFERENCE_C
    from thermoplc.recordings.table import write_table
    folder = Path(args.output)
    if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise UserError(f"-o {folder}: with --runs, a new or empty folder (the runs and runs.csv are written in it)")
    runs = plan(args.runs, args.seed, effects, args.effect_runs, args.ambient_levels)
    files, rows = [], ["file,hall_air_C,hall,air,start,seed,effects"]
    for run in runs:
        name = f"run_{run.index + 1:03d}.csv"
        columns = _as_written(args, simulate_run(args.machine, run, args.hours, _simulated_period(args),
                                                 args.probe_minutes, args.noise), run.seed)
        files.append((folder / name, write_table(columns)))
        rows.append(",".join([name, *run.attributes().values()]))
    files.append((folder / "runs.csv", "\n".join(rows) + "\n"))
    write_outputs(files)
    probing = f", drift probed every {args.probe_minutes:g} min and held" if args.probe_minutes else ""
    if args.ambient_levels:
        probing += (f", hall air stepped from {REFERENCE_C:g} to {','.join(f'{v:g}' for v in args.ambient_levels)} "
                    f"degC in turn")
    print(f"wrote {folder}: {len(runs)} run{'s' if len(runs) != 1 else ''} of {args.hours:g} h {_pace(args)}, "
          f"seed {args.seed}, machine "
          f"{args.machine}{probing}; runs table {folder / 'runs.csv'}")
    for e in effects:
        where = "every run" if args.effect_runs is None else "runs " + ",".join(map(str, args.effect_runs))
        print(f"  hidden effect {e.name} in {where}: " + ", ".join(
            f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in e.parameters))
    return 0
