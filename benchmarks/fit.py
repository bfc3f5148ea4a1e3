"""Fit time of the Kalman model (paper 000's GA, population 40 x 60 generations) on two datasets.

    python benchmarks/fit.py

FL_THERMAL as the demo fits it (ch3, t5_C/t1_C, 24 h of 11 k rows for training), and a week
of 10 s twin data (60 k rows; the last day is held out), with the GA and with scipy's differential
evolution. Targets from issue 6: under 20 s and under 60 s. One run, wall-clock seconds.
"""
from __future__ import annotations

import tempfile
from dataclasses import replace
import time
from pathlib import Path

from thermoplc.demo import AMBIENT, SPEED, TARGET, TEMPS, TRAIN_UNTIL_S, recording
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.recordings.table import read_table, write_table
from thermoplc.machines.cascade import simulate


def main() -> None:
    fl = read_table(recording())
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "week.csv"
        path.write_text(write_table(simulate(168, seed=2)))
        week = read_table(path)
    cases = [("FL_THERMAL ch3 (demo)", fl, FitRequest("kalman", TARGET, TEMPS, SPEED, AMBIENT, train_until=TRAIN_UNTIL_S),
              20.0),
             ("twin, one week at 10 s", week, FitRequest("kalman", "E_z_um", ("T_motor", "T_bearing"), "n_rpm", "T_env",
                                                         train_rows=week.rows - 8640), 60.0)]
    print(f"{'dataset':<26}{'rows':>8}{'train rows':>12}{'optimizer':>11}{'seconds':>9}{'target s':>10}"
          f"{'held-out RMSE um':>18}")
    for label, table, request, target in cases:
        for optimizer in ("ga", "de"):
            start = time.perf_counter()
            model = fit([table], replace(request, settings={"optimizer": optimizer}))
            seconds = time.perf_counter() - start
            held = model.metrics["held_out"]["rmse_um"] if model.metrics.get("held_out") else float("nan")
            print(f"{label:<26}{table.rows:>8}{model.metrics['train']['rows']:>12}{optimizer:>11}{seconds:>9.1f}"
                  f"{target:>10.0f}{held:>18.3f}", flush=True)


if __name__ == "__main__":
    main()
