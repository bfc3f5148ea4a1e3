"""The known start (issue 61, models/start.py): every kind's block at power-on, with and without it.

    python benchmarks/start.py [--quick]

On FL_THERMAL ch3 (the demo's sensors, fit on the first 24 h) and on the cascade twin (seed 3, 48 h, fit on the
first 24 h), for each kind: the block's output at its first call against the measured drift there, the largest
error over the first 10 and 30 min (the block as the PLC runs it: guards, rate limit, clamp), and the held-out
RMSE of the model, each with the fitted start and with the start taken out of the same model (what every block
did before). Last the fused mlr block of FL_THERMAL (`fit --probe --probe-every 120`), whose first probing comes
after 30 min. `--quick`: mlr, kalman, dlag and gm1n only. Seeded: the same run prints the same table.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from thermoplc.demo import AMBIENT, SPEED, TEMPS, TARGET, recording
from thermoplc.base.errors import UserError
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.models.kinds import kind_of
from thermoplc.models.modelfile import load_model
from thermoplc.models.probing import probings, PROBE_NEW, PROBE_VALUE
from thermoplc.models.reference import block_outputs, model_inputs, predict
from thermoplc.models.safety import Limits
from thermoplc.recordings.table import read_table

KINDS = ("mlr", "kalman", "lumped", "dlag", "gm0n", "gm1n", "bayes", "bpnn", "piecewise")
QUICK = ("mlr", "kalman", "dlag", "gm1n")
TRAIN_S = 24 * 3600.0


def twin(folder: Path) -> Path:
    path = folder / "twin.csv"
    subprocess.run([sys.executable, "-m", "thermoplc", "twin", "--hours", "48", "--seed", "3", "-o", str(path)],
                   check=True, capture_output=True)
    return path


def figures(model, table, split: int, probe_every: int | None = None) -> tuple[float, float, float, float]:
    """(first call error, max error in the first 10 min, in the first 30 min, held-out RMSE) of the block."""
    inputs = model_inputs(model, table)
    measured = table.columns[model.target.column]
    if probe_every:
        value, new = probings(measured, probe_every)
        inputs = {**inputs, PROBE_VALUE: value, PROBE_NEW: new}
    out = block_outputs(model, inputs, "f32", Limits())[model.target.name].astype(np.float64)
    elapsed = table.columns["time_s"] - table.columns["time_s"][0]
    error = np.abs(out - measured)
    held = predict(model, model_inputs(model, table), "f64")[model.target.name][split:] - measured[split:]
    held_rmse = float(np.sqrt(np.mean(held ** 2))) if not probe_every else float(np.sqrt(np.mean(error[split:] ** 2)))
    return float(error[0]), float(error[elapsed <= 600].max()), float(error[elapsed <= 1800].max()), held_rmse


def row(label: str, kind: str, with_start, without) -> None:
    print(f"{label:<12}{kind:<11}" + "".join(f"{a:>9.2f}{b:>8.2f}" for a, b in zip(with_start, without)), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    kinds = QUICK if parser.parse_args().quick else KINDS
    folder = Path(tempfile.mkdtemp(prefix="thermoplc-start-"))
    data = {"FL_THERMAL": (recording(), TARGET, TEMPS, SPEED, AMBIENT),
            "twin": (twin(folder), "E_z_um", ("T_motor", "T_bearing"), "n_rpm", "T_env")}
    print("each pair: with the known start, without it (the same model); um")
    print(f"{'data':<12}{'kind':<11}{'first call':>17}{'first 10 min':>17}{'first 30 min':>17}{'held-out RMSE':>17}")
    for label, (path, target, temps, speed, ambient) in data.items():
        table = read_table(path)
        split = int(np.searchsorted(table.columns["time_s"], table.columns["time_s"][0] + TRAIN_S, side="right"))
        for kind in kinds:
            roles = kind_of(kind).roles
            request = FitRequest(kind, target, temps, speed if "speed" in roles else None,
                                 ambient if "ambient" in roles else None, train_rows=split, settings={"seed": 0})
            try:
                model = fit([table], request)
            except UserError as exc:
                print(f"{label:<12}{kind:<11}refused: {str(exc).split(': ', 1)[-1][:90]}")
                continue
            row(label, kind, figures(model, table, split), figures(replace(model, start=None), table, split))
    model_path = folder / "fused.json"
    subprocess.run([sys.executable, "-m", "thermoplc", "fit", "--data", str(recording()), "--model", "mlr",
                    "--target", TARGET, "--temps", ",".join(TEMPS), "--train-until", str(TRAIN_S), "--probe",
                    "--probe-every", "120", "-o", str(model_path)], check=True, capture_output=True)
    fused = load_model(model_path)
    table = read_table(recording())
    split = int(np.searchsorted(table.columns["time_s"], table.columns["time_s"][0] + TRAIN_S, side="right"))
    row("FL_THERMAL", "mlr fused", figures(fused, table, split, 120), figures(replace(fused, start=None), table, split,
                                                                               120))
    print("fused: held-out RMSE of the block over every held-out call, a probing every 120 calls (30 min)")


if __name__ == "__main__":
    main()
