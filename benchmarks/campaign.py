"""Campaigns: every kind judged on runs it never saw, beside no compensation and a ridge on every sensor.

The ridge on every sensor's rise is the floor any compensation tool must beat. Each kind runs on
sensors named by hand and with `--choose-sensors 4` (chosen again inside every fold); the kinds that shrink take
every sensor in a third row (mlr, dlag and the grey kinds by their ridge weight, bayes by `--parents ridge`, bpnn
by `--skip ridge`).
Real data first: FL_THERMAL (46 h) cut into runs of 6 h, each a fresh block start with its
drift taken from the run's start (as a probing campaign measures it), full rate and probed every 30
minutes (held). Then twin campaigns of both machines over several seeds: leave one run out, grouped
(fit on the cool days, predict the warm ones: the runs table's `hall`), and probed every 30 min.
Seconds are per fit on this machine (2 cores, shared: noisy; compare within one run). "as blocks": each held-out
run replayed through its fold's block with the guards and limits from its training runs, pooled; "flagged": the runs
on which such a block raised a fault or SensorsDisagree.

    python -m benchmarks.campaign            # the whole table (about 15 min on 2 cores)
    python -m benchmarks.campaign --quick    # the real data and one twin campaign
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import argparse
import math
import time
from pathlib import Path

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.machines.campaign import TARGET, plan, simulate_run
from thermoplc.base import ridge
from thermoplc.recordings.campaign import Campaign, Run, held_to_probed
from thermoplc.fitting.crossval import as_the_block_runs, cross_validate_runs, pooled
from thermoplc.fitting.fit import FitRequest
from thermoplc.models.kinds import kind_of
from thermoplc.recordings.table import Table, read_table

ROOT = Path(__file__).resolve().parent.parent
FL_THERMAL = ROOT / "thermoplc" / "data" / "fl_thermal" / "fl_thermal.csv"
KINDS = ("mlr", "dlag", "gm0n", "gm1n", "bayes", "bpnn", "lumped", "kalman")
QUICK_GA = {"population": 20, "generations": 15}  # kalman's GA held short so the table runs in minutes
FL_RUN_HOURS = 6.0
CHOOSE = 4  # each kind's second row: at most this many sensors chosen from every sensor, inside each fold
# each kind's third row, where it has one: every sensor through a ridge weight chosen leaving out each run (issue 62)
EVERY_SENSOR = {"mlr": {}, "dlag": {}, "gm0n": {}, "gm1n": {}, "bayes": {"parents": "ridge"},
                "bpnn": {"skip": "ridge"}}


def fl_thermal_runs(target: str, hours: float, probe_minutes: float) -> list[Table]:
    """FL_THERMAL cut into runs of `hours`, each a fresh start: time and drift from the run's first row."""
    whole = read_table(FL_THERMAL)
    t = whole.columns["time_s"]
    dt = float(np.median(np.diff(t)))
    rows = int(round(hours * 3600 / dt))
    runs = []
    for k, start in enumerate(range(0, whole.rows - rows // 2, rows)):
        stop = min(start + rows, whole.rows)
        columns = {c: v[start:stop].copy() for c, v in whole.columns.items()}
        columns["time_s"] = columns["time_s"] - columns["time_s"][0]
        columns[target] = columns[target] - columns[target][0]
        if probe_minutes:
            step = int(round(probe_minutes * 60 / dt))
            columns[target] = columns[target][(np.arange(stop - start) // step) * step]
        table = Table(f"fl_thermal_run{k + 1}.csv", columns, f"{whole.sha256}:{start}", whole.lines[start:stop])
        runs.append(held_to_probed(table, target) if probe_minutes else table)
    return runs


def twin_runs(machine: str, seed: int, runs: int, hours: float, probe_minutes: float) -> Campaign:
    plans = plan(runs, seed)
    out = []
    for p in plans:
        columns = simulate_run(machine, p, hours, 60.0, probe_minutes)
        table = Table(f"{machine}_s{seed}_run{p.index + 1:02d}.csv", columns, f"{machine}:{p.seed}",
                      np.arange(2, len(columns["time_s"]) + 2))
        out.append(Run(held_to_probed(table, TARGET) if probe_minutes else table, p.attributes()))
    return Campaign(tuple(out), tuple(plans[0].attributes()))


def ridge_floor(tables: list[Table], target: str, temps: tuple[str, ...], groups=None) -> dict:
    """The issue's floor: ridge on every sensor's rise since its run's start, each run (or group) predicted by
    the fit on the others, the weight the one best on those same folds (so a slightly optimistic floor)."""
    folds = list(groups.values()) if groups else [[k] for k in range(len(tables))]
    rises, ys = [], []
    for fold in folds:  # the runs of a fold stacked as one "run": ridge.leave_one_run_out leaves it out whole
        keep = [np.isfinite(tables[k].columns[target]) for k in fold]
        rises.append(np.vstack([np.column_stack([tables[k].columns[c] - tables[k].columns[c][0] for c in temps])[m]
                                for k, m in zip(fold, keep)]))
        ys.append(np.concatenate([tables[k].columns[target][m] for k, m in zip(fold, keep)]))
    y = np.concatenate(ys)
    rmse = min(ridge.leave_one_run_out(np.vstack(rises), y, [len(v) for v in ys], ridge.WEIGHTS))
    return {"rmse": rmse, "zero": float(np.sqrt(np.mean(y ** 2))), "rows": len(y)}


def judge(tables: list[Table], request: FitRequest, groups=None) -> dict:
    started = time.perf_counter()
    try:
        folds, per_run = cross_validate_runs(tables, request, "time_s", None, groups)
    except UserError as exc:
        return {"kind": request.kind, "refused": str(exc)[:70]}
    seconds = (time.perf_counter() - started) / len(folds)
    held = pooled(folds)
    blocks = as_the_block_runs(per_run)
    return {"kind": request.kind, "rmse": held["rmse_um"], "zero": held["zero_rmse_um"], "rows": held["rows"],
            "block": blocks.get("block_rmse_um", math.nan), "flagged": len(blocks.get("block_flagged_runs", ())),
            "worst": max(f.rmse for f in folds), "median": float(np.median([f.rmse for f in folds])),
            "seconds_per_fit": seconds}


def request_for(kind: str, target: str, temps: tuple[str, ...], speed: str, ambient: str, choose: int = 0,
                settings: dict | None = None) -> FitRequest:
    return FitRequest(kind=kind, target=target, temps=temps, speed=speed, ambient=ambient,
                      settings=QUICK_GA if kind == "kalman" else (settings or {}), train_until=math.inf,
                      choose_sensors=choose)


def table_rows(label: str, tables: list[Table], target: str, temps: tuple[str, ...], every: tuple[str, ...],
               speed: str, ambient: str, groups=None, kinds=KINDS) -> list[str]:
    floor = ridge_floor(tables, target, every, groups)
    lines = [f"{label}: {len(tables)} runs, {floor['rows']} measured rows; no compensation {floor['zero']:.2f} um, "
             f"ridge on all {len(every)} sensors' rises {floor['rmse']:.2f} um",
             f"  {'kind':<8}{'sensors':<22}{'RMSE um':>9}{'worst fold':>11}{'median':>8}{'/ridge':>8}  {'':<16}{'s/fit':>7}"
             f"{'as blocks':>10}{'flagged':>8}"]
    for kind in kinds:
        choices = tuple(c for c in every if c != ambient) if kind_of(kind).ambient_apart else every
        rows = [(temps, 0, None), (choices, CHOOSE, None)]
        if kind in EVERY_SENSOR:
            rows.append((choices, 0, EVERY_SENSOR[kind]))
        for sensors, choose, settings in rows:
            found = judge(tables, request_for(kind, target, sensors, speed, ambient, choose, settings), groups)
            named = (f"best {choose} of {len(choices)}" if choose else
                     f"all {len(choices)}" + (", " + ",".join(f"{v}" for v in settings.values()) if settings else "")
                     if settings is not None else ",".join(sensors))
            if "refused" in found:
                lines.append(f"  {kind:<8}{named[:21]:<22}refused: {found['refused']}")
                continue
            verdict = "beats none" if found["rmse"] < found["zero"] else "WORSE than none"
            lines.append(f"  {kind:<8}{named[:21]:<22}{found['rmse']:>9.2f}{found['worst']:>11.2f}{found['median']:>8.2f}"
                         f"{found['rmse'] / floor['rmse']:>8.2f}  {verdict:<16}{found['seconds_per_fit']:>7.2f}"
                         f"{found['block']:>10.2f}{found['flagged']:>8}")
    return lines


def scale_campaign(runs: int = 40, hours: float = 6.0, dt: float = 40.0, sensors: int = 23) -> list[Table]:
    """The issue's size: `runs` runs of `hours` at `dt` with `sensors` temperatures: the cascade's five,
    and mixtures of its nodes lagged and noisy (as extra sensors on a real machine read neighbouring
    heat paths)."""
    rng = np.random.default_rng(40)
    tables = []
    for p in plan(runs, 40):
        columns = simulate_run("cascade", p, hours, dt, 30.0)
        nodes = np.column_stack([columns[c] for c in ("T_motor", "T_bearing", "T_struct", "T_base", "T_env")])
        for k in range(sensors - 5):
            weights = rng.dirichlet(np.ones(5))
            lag = int(rng.integers(1, 30))
            mixed = nodes @ weights
            mixed = np.r_[np.full(lag, mixed[0]), mixed[:-lag]] + rng.normal(0, 0.05, len(mixed))
            columns[f"T_x{k + 1:02d}"] = np.round(mixed, 3)
        table = Table(f"scale_run{p.index + 1:02d}.csv", columns, f"scale:{p.seed}",
                      np.arange(2, len(columns["time_s"]) + 2))
        tables.append(held_to_probed(table, TARGET))
    return tables


def scale_timings() -> list[str]:
    """Seconds for the issue's targets: auto leave-one-run-out and one kind, 40 runs x 6 h at 40 s, 23 sensors."""
    from thermoplc.fitting.auto import rank
    tables = scale_campaign()
    temps = tuple(c for c in tables[0].columns if c.startswith("T_"))
    lines = [f"## scale: {len(tables)} runs x 6 h at 40 s, {len(temps)} sensors, probed every 30 min"]
    for kind in ("mlr", "dlag", "gm1n", "bayes"):
        request = FitRequest(kind=kind, target=TARGET, temps=temps[:4] if kind == "bayes" else temps,
                             train_until=math.inf)
        found = judge(tables, request)
        lines.append(f"  {kind:<8} leave-one-run-out: {found['seconds_per_fit'] * len(tables):6.1f} s for "
                     f"{len(tables)} folds, {found['seconds_per_fit']:.2f} s per fit")
    request = FitRequest(kind="auto", target=TARGET, temps=temps, train_until=math.inf)
    started = time.perf_counter()
    ranked = rank(tables, request, len(tables), "time_s")
    ranking = time.perf_counter() - started
    best = next(c for c in ranked if c.model is not None)
    held = best.model.metrics["held_out"]
    lines.append(f"  auto     leave-one-run-out, each kind choosing its sensors in every fold: {ranking:.1f} s "
                 f"({len(ranked)} candidates, best {best.kind} on {','.join(best.sensors)}); RMSE {held['rmse_um']:.2f} "
                 f"um, none {held['zero_rmse_um']:.2f} um")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="real data and one twin campaign only")
    parser.add_argument("--seeds", type=int, default=2, help="twin seeds per machine (default 2)")
    parser.add_argument("--scale", action="store_true", help="only the timings at the issue's size")
    args = parser.parse_args()
    if args.scale:
        print("\n".join(scale_timings()))
        return
    print("## FL_THERMAL cut into 6 h runs (real data; drift from each run's start)")
    every = tuple(f"t{i}_C" for i in range(1, 17) if i != 6)
    for target, temps in (("ch3_um", ("t5_C", "t4_C")), ("ch5_um", ("t8_C", "t4_C", "t5_C", "t11_C"))):
        for probe in (0.0, 30.0):
            runs = fl_thermal_runs(target, FL_RUN_HOURS, probe)
            label = f"FL_THERMAL {target}, {'probed every 30 min' if probe else 'full rate'}"
            print("\n".join(table_rows(label, runs, target, temps, every, "spindle_rpm", "t6_C")))
    temps = ("T_motor", "T_bearing", "T_struct")
    every = ("T_env", "T_motor", "T_bearing", "T_struct", "T_base")
    cases = [("cascade", 1)] if args.quick else [(m, s) for m in ("cascade", "portal") for s in range(1, args.seeds + 1)]
    for machine, seed in cases:
        print(f"\n## twin campaign: machine {machine}, seed {seed}, 10 runs of 6 h at 60 s")
        campaign = twin_runs(machine, seed, 10, 6.0, 0.0)
        machine_temps = temps if machine == "cascade" else tuple(c for c in campaign.tables[0].columns
                                                               if c.startswith("T_") and c != "T_env")[:3]
        machine_every = tuple(c for c in campaign.tables[0].columns if c.startswith("T_"))
        tables = campaign.tables
        print("\n".join(table_rows("leave one run out", tables, TARGET, machine_temps, machine_every, "n_rpm",
                                   "T_env")))
        print("\n".join(table_rows("grouped: cool runs predict warm ones and back", tables, TARGET, machine_temps,
                                   machine_every, "n_rpm", "T_env", campaign.groups("hall"))))
        probed = twin_runs(machine, seed, 10, 6.0, 30.0).tables
        print("\n".join(table_rows("probed every 30 min (held)", probed, TARGET, machine_temps, machine_every,
                                   "n_rpm", "T_env")))


if __name__ == "__main__":
    main()
