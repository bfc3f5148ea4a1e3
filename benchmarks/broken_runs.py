"""A broken run in a campaign (issue 62, item 2): found, named, refused for training, and what it costs.

Real data first: FL_THERMAL cut into runs (3 h and 6 h, each a fresh start), then twin campaigns of both machines
(10 runs of 6 h, seeds 1-3). Each campaign clean, then with one run's first model sensor broken from mid-run:
  jump    6.5 K in one call, then rising 25 K more (the lathe campaign's broken run)
  swap    its connector swapped with the second sensor's
  offset  3 K from a third of the run (a connection working loose)
  dead    the first reading held to the end
Per case: the runs refused (the rule of fitting/broken_runs.py) and named, and mlr's held-out RMSE (leave one run
out) over the sound runs: fitted on the campaign without the broken run (the reference), on the campaign with it as
`fit` does (screened), and with `--keep-every-run`. "ratio" is screened / reference: within 1.10 is the issue's bar.

    python -m benchmarks.broken_runs            # every campaign (a few minutes on 2 cores)
    python -m benchmarks.broken_runs --quick    # FL_THERMAL 6 h runs only
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import argparse
import math
from dataclasses import replace

import numpy as np

from benchmarks.campaign import fl_thermal_runs, twin_runs
from thermoplc.fitting.broken_runs import screen_runs
from thermoplc.fitting.crossval import fit_held_out
from thermoplc.fitting.fit import FitRequest
from thermoplc.machines.campaign import TARGET
from thermoplc.recordings.table import Table

FAULTS = ("jump", "swap", "offset", "dead")
BROKEN = 3  # the run broken (0-based)


def broken(table: Table, fault: str, sensor: str, other: str) -> Table:
    columns = dict(table.columns)
    n = table.rows
    x = np.asarray(columns[sensor], float).copy()
    if fault == "jump":
        x[n // 2:] += 6.5 + np.linspace(0.0, 25.0, n - n // 2)
    elif fault == "swap":
        x, columns[other] = np.asarray(columns[other], float).copy(), x
    elif fault == "offset":
        x[n // 3:] += 3.0
    elif fault == "dead":
        x[:] = x[0]
    columns[sensor] = x
    return replace(table, columns=columns)


def sound_rmse(model, skip: str | None) -> float:
    """Pooled held-out RMSE over the runs other than `skip` (by file name)."""
    runs = [r for r in model.metrics["runs"] if r["run"] != skip]
    return math.sqrt(sum(r["rmse"] ** 2 * r["rows"] for r in runs) / sum(r["rows"] for r in runs))


def cases(quick: bool) -> list[tuple[str, list[Table], str, tuple[str, ...]]]:
    every = tuple(f"t{i}_C" for i in range(1, 17) if i != 6)
    found = []
    for hours in ((6.0,) if quick else (3.0, 6.0)):
        for target, temps in (("ch3_um", ("t5_C", "t4_C")), ("ch5_um", ("t8_C", "t4_C", "t5_C", "t11_C")),
                              ("ch5_um", every)):
            found.append((f"FL_THERMAL {hours:g} h runs {target[:3]} {len(temps)} sensors",
                          fl_thermal_runs(target, hours, 0), target, temps))
    if not quick:
        for machine in ("cascade", "portal"):
            for seed in (1, 2, 3):
                tables = twin_runs(machine, seed, 10, 6.0, 0.0).tables
                temps = tuple(c for c in tables[0].columns if c.startswith("T_") and c != "T_env")[:3]
                found.append((f"twin {machine} seed {seed}, 10 runs", tables, TARGET, temps))
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="FL_THERMAL 6 h runs only")
    args = parser.parse_args()
    print(f"{'campaign':<44}{'fault':<8}{'refused':<22}{'named':>6}{'reference':>11}{'screened':>10}{'kept':>9}"
          f"{'ratio':>7}")
    worst = 0.0
    for label, tables, target, temps in cases(args.quick):
        request = FitRequest(kind="mlr", target=target, temps=temps, train_until=math.inf)
        for fault in (None, *FAULTS):
            runs = list(tables)
            if fault:
                runs[BROKEN] = broken(runs[BROKEN], fault, temps[0], temps[1])
            screening = screen_runs(runs, temps, target)
            refused = ",".join(f"{r.run.split('_')[-1]}:{r.sensor}" for r in screening.refused) or "-"
            name = runs[BROKEN].path if fault else None
            screened = sound_rmse(fit_held_out(runs, request, len(runs)), name)
            cells = f"{'':>11}{screened:>10.2f}{'':>9}{'':>7}"
            if fault:
                reference = sound_rmse(fit_held_out(runs[:BROKEN] + runs[BROKEN + 1:], request, len(runs) - 1), None)
                kept = sound_rmse(fit_held_out(runs, replace(request, keep_every_run=True), len(runs)), name)
                worst = max(worst, screened / reference)
                cells = f"{reference:>11.2f}{screened:>10.2f}{kept:>9.2f}{screened / reference:>7.2f}"
            print(f"{label:<44}{fault or 'clean':<8}{refused[:21]:<22}{len(screening.named):>6}{cells}")
    print(f"worst screened / reference: {worst:.2f}")


if __name__ == "__main__":
    main()
