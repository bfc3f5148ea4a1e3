"""Probe fusion (issue 49): what a block that takes the machine's probings gains over its static model.

Real data first: FL_THERMAL (46 h) cut into runs of `--run-hours` (each a fresh block start, the drift from
the run's start), ch3 and ch5 on t4, t5, t8, t11. Then twin campaigns of both machines (six runs of 6 h,
hall air 14-34 degC, cold and warm starts) on their true drift at every call. Each kind is fitted leave one
run out; its held-out predictions are replayed with a probing every 15, 30, 60 and 120 min through
  - the static block (no probings), the plain offset reset (the last probing's residual, gain 1) and
  - the fused block, its gain, drift rate, decay and gate chosen on the other runs (nested), and for the linear
    kinds its static part refitted for the change since the last probing where that wins ("refitted": r per
    schedule, 15/30/60/120 min),
beside no compensation: RMSE over every call, pooled over the runs and for the worst run. Seconds: the static
leave-one-run-out fit, and the fusion's choice over all schedules, on this machine (2 cores, shared: noisy).

    python -m benchmarks.probing            # FL_THERMAL and both twins, five kinds (a few minutes)
    python -m benchmarks.probing --quick    # FL_THERMAL ch3, mlr and dlag
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import argparse
import time

import numpy as np

from benchmarks.campaign import fl_thermal_runs, twin_runs
from thermoplc.machines.campaign import TRUTH
from thermoplc.fitting.crossval import fit_held_out
from thermoplc.fitting.fit import FitRequest
from thermoplc.fitting.probe_fit import REFITTED, SCHEDULES_MIN, fit_probe

FL_TEMPS = ("t4_C", "t5_C", "t8_C", "t11_C")
TWIN_TEMPS = {"cascade": ("T_motor", "T_bearing", "T_struct"), "portal": ("T_spindle", "T_gearbox", "T_column")}
KINDS = ("mlr", "dlag", "gm0n", "gm1n", "bayes")


def datasets(quick: bool, run_hours: float) -> list[tuple[str, list, str, tuple[str, ...]]]:
    """(name, runs, target, temperatures), real data first."""
    found = [(f"FL_THERMAL {channel[:3]}, runs of {run_hours:g} h", fl_thermal_runs(channel, run_hours, 0), channel,
              FL_TEMPS) for channel in (("ch3_um",) if quick else ("ch3_um", "ch5_um"))]
    if not quick:
        for machine in ("cascade", "portal"):
            campaign = twin_runs(machine, 7, 6, 6.0, 0)
            found.append((f"twin {machine}, 6 runs of 6 h", campaign.tables, TRUTH, TWIN_TEMPS[machine]))
    return found


def one(kind: str, tables: list, target: str, temps: tuple[str, ...]) -> dict:
    """The kind fitted leave one run out, then fused as `fit --probe --probe-every N` does for each schedule (the
    static part refitted for the change since the last probing where that wins on the other runs)."""
    request = FitRequest(kind=kind, target=target, temps=temps, train_until=None, train_rows=None)
    predictions: dict = {}
    started = time.perf_counter()
    model = fit_held_out(tables, request, len(tables), predictions=predictions)
    fitted = time.perf_counter() - started
    started = time.perf_counter()
    figures = {}
    for minutes in SCHEDULES_MIN:
        every = max(int(round(minutes * 60 / model.sample_period_s)), 1)
        figures[minutes] = fit_probe(model, tables, predictions, every, False).metrics["probing"]
    return {"fit_s": fitted, "probe_s": time.perf_counter() - started, "figures": figures}


def worst(summary: dict, method: str) -> float:
    return max(row[f"{method}_rmse_um"] for row in summary["runs"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="FL_THERMAL ch3 only, mlr and dlag")
    parser.add_argument("--run-hours", type=float, default=6.0, help="FL_THERMAL cut into runs of this length")
    args = parser.parse_args()
    kinds = ("mlr", "dlag") if args.quick else KINDS
    head = "".join(f"{f'{m} min fused (worst)':>22}{'reset':>7}" for m in SCHEDULES_MIN)
    head += f"{'fused/static 30':>17}{'fused/reset 30':>16}{'refitted':>10}"
    for name, tables, target, temps in datasets(args.quick, args.run_hours):
        print(f"\n{name}: leave one run out, RMSE um over every call, pooled (worst run)")
        print(f"{'kind':<7}{'none':>7}{'static (worst)':>17}{head}{'fit s':>7}{'probe s':>8}")
        for kind in kinds:
            result = one(kind, tables, target, temps)
            f = result["figures"]
            pooled = {m: f[m]["pooled"] for m in SCHEDULES_MIN}
            cells = "".join(f"{pooled[m]['fused_rmse_um']:>11.2f} ({worst(f[m], 'fused'):>6.2f}){pooled[m]['reset_rmse_um']:>10.2f}"
                            for m in SCHEDULES_MIN)
            static = pooled[30]["static_rmse_um"]
            refitted = "".join("r" if f[m]["static"] == REFITTED else "-" for m in SCHEDULES_MIN)
            print(f"{kind:<7}{pooled[30]['none_rmse_um']:>7.2f}{static:>9.2f} ({worst(f[30], 'static'):>6.2f}){cells}"
                  f"{pooled[30]['fused_rmse_um'] / static:>17.2f}"
                  f"{pooled[30]['fused_rmse_um'] / pooled[30]['reset_rmse_um']:>16.2f}{refitted:>10}"
                  f"{result['fit_s']:>7.1f}{result['probe_s']:>8.1f}")


if __name__ == "__main__":
    main()
