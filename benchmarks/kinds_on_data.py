"""Every kind fitted on FL_THERMAL ch3 and on the cascade twin, as the safety benchmarks (start, faults,
limits) judge them: the demo's sensors, fit on the first 24 h; the twin seed 3, 48 h. Seeded."""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import subprocess
import sys
from pathlib import Path
from typing import Iterator

import numpy as np

from thermoplc.demo import AMBIENT, SPEED, TARGET, TEMPS, recording
from thermoplc.base.errors import UserError
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.models.kinds import kind_of
from thermoplc.models.modelfile import load_model
from thermoplc.models.model import Model
from thermoplc.recordings.table import Table, read_table

TRAIN_S = 24 * 3600.0
PROBE_EVERY = 120  # calls between probings of the fused blocks (30 min on FL_THERMAL)


def twin(folder: Path) -> Path:
    path = folder / "twin.csv"
    subprocess.run([sys.executable, "-m", "thermoplc", "twin", "--hours", "48", "--seed", "3", "-o", str(path)],
                   check=True, capture_output=True)
    return path


def datasets(folder: Path) -> dict[str, tuple[Path, str, tuple[str, ...], str, str]]:
    """label -> (CSV, target, temperatures, speed, ambient)."""
    return {"FL_THERMAL": (recording(), TARGET, TEMPS, SPEED, AMBIENT),
            "twin": (twin(folder), "E_z_um", ("T_motor", "T_bearing"), "n_rpm", "T_env")}


def split_row(table: Table) -> int:
    """The first held-out row: after TRAIN_S."""
    time = table.columns["time_s"]
    return int(np.searchsorted(time, time[0] + TRAIN_S, side="right"))


def fitted_kinds(folder: Path, kinds: tuple[str, ...]) -> Iterator[tuple[str, str, Table, Model | str]]:
    """(data, kind, table, model or why fit refused it) for every data set and kind."""
    for label, (path, target, temps, speed, ambient) in datasets(folder).items():
        table = read_table(path)
        for kind in kinds:
            roles = kind_of(kind).roles
            request = FitRequest(kind, target, temps, speed if "speed" in roles else None,
                                 ambient if "ambient" in roles else None, train_rows=split_row(table),
                                 settings={"seed": 0})
            try:
                yield label, kind, table, fit([table], request)
            except UserError as exc:
                yield label, kind, table, str(exc).split(": ", 1)[-1][:90]
        yield label, "mlr fused", table, fused(folder, path, target, temps)


def fused(folder: Path, data: Path, target: str, temps: tuple[str, ...]) -> Model:
    """The fused mlr block of `data`, as `fit --probe --probe-every 120` writes it."""
    path = folder / f"fused_{data.stem}.json"
    subprocess.run([sys.executable, "-m", "thermoplc", "fit", "--data", str(data), "--model", "mlr", "--target",
                    target, "--temps", ",".join(temps), "--train-until", str(TRAIN_S), "--probe", "--probe-every",
                    str(PROBE_EVERY), "-o", str(path)], check=True, capture_output=True)
    return load_model(path)
