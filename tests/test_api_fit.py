"""`thermoplc.api.fit` writes what `thermoplc fit` writes, byte for byte (issue 66): every kind, `auto`, a
campaign with folds, a fused block (--probe), a held target and --resample. Both go through app/fit_pipeline.py;
a check or a step that only the command made would show here as a different file."""
from pathlib import Path

import numpy as np
import pytest

from tests.cli_runner import thermoplc
from tests.golden_models import batch_csvs
from thermoplc import api
from thermoplc.machines.cascade import simulate
from thermoplc.models.kinds import kind_of, names, options, readers
from thermoplc.recordings.table import write_table

TEMPS = ("T_motor", "T_bearing")
SMALL = {"seed": 1, "population": 8, "generations": 3}  # the iterative kinds' search kept short


def _settings(kind: str) -> dict:
    return {field: value for field, value in SMALL.items() if kind in {k.name for k in readers(field)}}


def _flags(settings: dict) -> list[str]:
    return [text for field, value in settings.items() for text in (options()[field].flag, str(value))]


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("apifit")
    (folder / "twin.csv").write_text(write_table(simulate(8, seed=7)))
    for k in range(3):
        (folder / f"run_{k}.csv").write_text(write_table(simulate(4, seed=30 + k)))
    batch_csvs(folder)
    return folder


def _cli_bytes(folder: Path, *args) -> bytes:
    thermoplc("fit", *args, "-o", "cli.json", "--force", cwd=folder)
    return (folder / "cli.json").read_bytes()


def _api_bytes(paths: list[Path], request: api.FitRequest, plan: api.FitPlan | None = None) -> bytes:
    return api.fit([api.read_table(p) for p in paths], request, plan=plan).to_json().encode()


@pytest.mark.parametrize("kind", [*names(), "auto"])
def test_every_kind_and_auto_write_the_same_file(kind, folder):
    settings = _settings(kind)
    data = [f"batch_{t:g}C.csv" for t in (14.0, 19.0, 26.0, 31.0)] if kind == "piecewise" else ["twin.csv"]
    split = ["--folds", "4"] if kind == "piecewise" else ["--train-until", "18000"]
    roles = {"speed": "n_rpm", "ambient": "T_env"}
    if kind != "auto":  # auto tries each role with the kinds that read it
        roles = {role: column for role, column in roles.items() if role in kind_of(kind).roles}
    cli = _cli_bytes(folder, *(a for d in data for a in ("--data", d)), "--model", kind, "--target", "E_z_um",
                     "--temps", ",".join(TEMPS), *(a for role, c in roles.items() for a in (f"--{role}", c)), *split,
                     *_flags(settings))
    request = api.FitRequest(kind, "E_z_um", TEMPS, roles.get("speed"), roles.get("ambient"),
                             train_until=None if kind == "piecewise" else 18000.0, settings=settings)
    plan = api.FitPlan(folds=4) if kind == "piecewise" else None
    assert _api_bytes([folder / d for d in data], request, plan) == cli


def test_a_campaign_with_folds_a_fused_block_and_a_held_target(folder):
    """Three runs left out in turn, the target probed every 30 calls and held between, a fused block."""
    for k in range(3):
        path = folder / f"run_{k}.csv"
        table = api.read_table(path)
        held = table.columns["E_z_um"].copy()
        for start in range(0, len(held), 30):
            held[start:start + 30] = held[start]
        lines = path.read_text().splitlines()
        column = lines[0].split(",").index("E_z_um")
        rows = [line.split(",") for line in lines[1:]]
        for row, value in zip(rows, held):
            row[column] = repr(float(np.float64(value)))
        (folder / f"held_{k}.csv").write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")
    paths = [folder / f"held_{k}.csv" for k in range(3)]
    cli = _cli_bytes(folder, *(a for p in paths for a in ("--data", p.name)), "--model", "mlr", "--target", "E_z_um",
                     "--held-target", "--temps", ",".join(TEMPS), "--folds", "3", "--probe")
    request = api.FitRequest("mlr", "E_z_um", TEMPS)
    model = api.fit([api.read_table(p) for p in paths], request, plan=api.FitPlan(folds=3, probe=True, held_target=True))
    assert model.probe is not None
    assert model.to_json().encode() == cli


def test_resample_and_a_probing_schedule(folder):
    """The twin taken onto a 20 s cycle (its speed held), fused with a probing every 45 calls."""
    cli = _cli_bytes(folder, "--data", "twin.csv", "--model", "mlr", "--target", "E_z_um", "--temps", ",".join(TEMPS),
                     "--speed", "n_rpm", "--train-until", "18000", "--resample", "20", "--probe", "--probe-every", "45")
    request = api.FitRequest("mlr", "E_z_um", TEMPS, "n_rpm", train_until=18000.0)
    plan = api.FitPlan(probe=True, probe_every=45, resampling=api.Resampling.holding(20.0, ("n_rpm",)))
    model = api.fit([api.read_table(folder / "twin.csv")], request, plan=plan)
    assert model.resample is not None and model.sample_period_s == 20.0
    assert model.to_json().encode() == cli
