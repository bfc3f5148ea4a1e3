"""The known start (issue 61, models/start.py): every kind's block at power-on, with and without it.

    python benchmarks/start.py [--quick]

On FL_THERMAL ch3 (the demo's sensors, fit on the first 24 h) and on the cascade twin (seed 3, 48 h, fit on the
first 24 h), for each kind: the block's output at its first call against the measured drift there, the largest
error over the first 10 and 30 min (the block as the PLC runs it: guards, rate limit, clamp), and the held-out
RMSE of the model, each with the fitted start and with the start taken out of the same model (what every block
did before). Last per data the fused mlr block (`fit --probe --probe-every 120`), whose first probing comes after
30 min on FL_THERMAL. `--quick`: mlr, kalman, dlag and gm1n only. Seeded: the same run prints the same table.
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import argparse
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.kinds_on_data import PROBE_EVERY, fitted_kinds, split_row  # noqa: E402
from thermoplc.models.probing import probings, PROBE_NEW, PROBE_VALUE  # noqa: E402
from thermoplc.models.reference import block_outputs, model_inputs, predict  # noqa: E402
from thermoplc.models.safety import Limits  # noqa: E402

KINDS = ("mlr", "kalman", "lumped", "dlag", "gm0n", "gm1n", "bayes", "bpnn", "piecewise")
QUICK = ("mlr", "kalman", "dlag", "gm1n")


def figures(model, table, probe_every: int | None = None) -> tuple[float, float, float, float]:
    """(first call error, max error in the first 10 min, in the first 30 min, held-out RMSE) of the block."""
    split = split_row(table)
    inputs = model_inputs(model, table)
    measured = table.columns[model.target.column]
    if probe_every:
        value, new = probings(measured, probe_every)
        inputs = {**inputs, PROBE_VALUE: value, PROBE_NEW: new}
    out = block_outputs(model, inputs, "f32", Limits.for_model(model))[model.target.name].astype(np.float64)
    elapsed = table.columns["time_s"] - table.columns["time_s"][0]
    error = np.abs(out - measured)
    held = predict(model, model_inputs(model, table), "f64")[model.target.name][split:] - measured[split:]
    held_rmse = float(np.sqrt(np.mean(held ** 2))) if not probe_every else float(np.sqrt(np.mean(error[split:] ** 2)))
    return float(error[0]), float(error[elapsed <= 600].max()), float(error[elapsed <= 1800].max()), held_rmse


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    kinds = QUICK if parser.parse_args().quick else KINDS
    print("each pair: with the known start, without it (the same model); um")
    print(f"{'data':<12}{'kind':<11}{'first call':>17}{'first 10 min':>17}{'first 30 min':>17}{'held-out RMSE':>17}")
    for label, kind, table, model in fitted_kinds(Path(tempfile.mkdtemp(prefix="thermoplc-start-")), kinds):
        if isinstance(model, str):
            print(f"{label:<12}{kind:<11}refused: {model}")
            continue
        every = PROBE_EVERY if model.probe is not None else None
        pairs = zip(figures(model, table, every), figures(replace(model, start=None), table, every))
        print(f"{label:<12}{kind:<11}" + "".join(f"{a:>9.2f}{b:>8.2f}" for a, b in pairs), flush=True)
    print("fused: held-out RMSE of the block over every held-out call, a probing every 120 calls")


if __name__ == "__main__":
    main()
