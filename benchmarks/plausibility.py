"""The cross-sensor check (models/plausibility.py) judged on data it was not fitted on: how often it flags a sound
machine, and how much of a drifting sensor it sees.

    python -m benchmarks.plausibility

Per data set and sensor set: each checked temperature's gate as `fit` sets it (every row of the recording) and,
to judge it on rows it never saw, the gate from the training rows alone; with that gate, the share of held-out
calls on which SensorsDisagree would be set on the clean data (a false alarm: the block fades to no
compensation until the sensors agree again), and the share of calls flagged while paper 000's +2 sin(t/350) degC
or a -2 degC offset sits on that sensor from a third into the data, by the level test alone and with the swing
test (the difference leaving its 10-min mean). Data: FL_THERMAL (the demo's t5_C, t1_C with
the ambient t6_C; the issue's t8_C, t4_C, t5_C, t11_C), trained on the first 24 h; the twin's T_motor, T_bearing,
T_env, fitted on seed 3 and judged on seeds 3 (held-out half) and 7 (another machine's day). Seeded.
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.kinds_on_data import TRAIN_S, split_row  # noqa: E402
from thermoplc.demo import recording  # noqa: E402
from thermoplc.fitting.plausibility_fit import fit_plausibility  # noqa: E402
from thermoplc.models.model import Model, Signal  # noqa: E402
from thermoplc.models.plausibility import Plausibility, disagree  # noqa: E402
from thermoplc.recordings.table import Table, read_table  # noqa: E402
from thermoplc.verifier.replays.faults import FAULT_KINDS, inject  # noqa: E402

SETTLE_CALLS = 30  # generate's default
DRIFTS = [k for k in FAULT_KINDS if k.name in ("sine", "offset")]


AMBIENT = ("t6_C", "T_env")  # the hall air of FL_THERMAL and of the twin: no slope of any relation


def probe_model(sensors: tuple[str, ...]) -> Model:
    """A model that reads these temperatures (the check needs no more of it)."""
    role = lambda name: "ambient" if name in AMBIENT else "temperature"
    return Model(kind="mlr", block_name="Check", inputs=tuple(Signal(n, n, role(n), "degC") for n in sensors),
                 target=Signal("d", "d", "target", "um"), time_column="time_s", sample_period_s=15.0, coefficients={})


def level_only(plausibility: Plausibility) -> Plausibility:
    """The check without its swing test."""
    return Plausibility(tuple(replace(r, swing_K=None, largest_swing_K=None) for r in plausibility.relations))


def flagged(model: Model, plausibility, table: Table, overrides: dict | None = None) -> np.ndarray:
    values = {n: np.asarray((overrides or {}).get(n, table.columns[n]), np.float32) for n in plausibility.sensors()}
    return disagree(plausibility, values, SETTLE_CALLS, model.sample_period_s, "f32")


def judge(label: str, sensors: tuple[str, ...], fit_on: Table, train_rows: int, judged: list[tuple[str, Table, int]]):
    model = probe_model(sensors)
    every = fit_plausibility(model, [fit_on], [train_rows])
    trained = fit_plausibility(model, [Table(fit_on.path, {k: v[:train_rows] for k, v in fit_on.columns.items()},
                                             fit_on.sha256, fit_on.lines[:train_rows])], [train_rows])
    level = lambda r: f"{r.gate_K[0]:g}" if r.gate_K is not None else "-"
    gates = ", ".join(f"{r.sensor} {level(r)}/{r.swing_K[0]:g} ({level(t)}/{t.swing_K[0]:g})"
                      for r, t in zip(every.relations, trained.relations))
    print(f"{label}: gates K, level/swing, every row (training rows): {gates}")
    for name, table, first in judged:
        alarms, level = flagged(model, trained, table)[first:], flagged(model, level_only(trained), table)[first:]
        line = [f"  {name}: false alarms {100 * alarms.mean():.1f} % (level alone {100 * level.mean():.1f} %) of "
                f"{len(alarms)} held-out calls"]
        times = np.asarray(table.columns["time_s"], np.float64)
        start = table.rows // 3
        for sensor in sensors:
            for kind in DRIFTS:
                faulty, _ = inject(np.asarray(table.columns[sensor], np.float32), times, kind, start)
                seen = flagged(model, every, table, {sensor: faulty})[start:]
                by_level = flagged(model, level_only(every), table, {sensor: faulty})[start:]
                line.append(f"{sensor} {kind.name} {100 * seen.mean():.0f} % ({100 * by_level.mean():.0f} %)")
        print(line[0] + "; flagged while drifting, with the swing test (level alone): " + ", ".join(line[1:]),
              flush=True)


def main() -> None:
    fl = read_table(recording())
    first = split_row(fl)
    judge("FL_THERMAL demo", ("t5_C", "t1_C", "t6_C"), fl, first, [("FL_THERMAL after 24 h", fl, first)])
    judge("FL_THERMAL issue 61", ("t8_C", "t4_C", "t5_C", "t11_C"), fl, first, [("FL_THERMAL after 24 h", fl, first)])
    with tempfile.TemporaryDirectory() as tmp:
        twins = {}
        for seed in (3, 7):
            path = Path(tmp) / f"twin{seed}.csv"
            subprocess.run([sys.executable, "-m", "thermoplc", "twin", "--hours", "48", "--seed", str(seed), "-o",
                            str(path)], check=True, capture_output=True)
            twins[seed] = read_table(path)
        half = int(np.searchsorted(twins[3].columns["time_s"], TRAIN_S, side="right"))
        judge("twin seed 3", ("T_motor", "T_bearing", "T_env"), twins[3], half,
              [("twin seed 3 after 24 h", twins[3], half), ("twin seed 7, all 48 h", twins[7], 0)])


if __name__ == "__main__":
    main()
