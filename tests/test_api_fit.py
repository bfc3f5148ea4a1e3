"""`thermoplc.api.fit` writes what `thermoplc fit` writes, byte for byte (issue 66): every kind, `auto`, a
campaign with folds, a fused block (--probe), a held target and --resample. Both go through thermoplc/fit_pipeline.py;
a check or a step that only the command made would show here as a different file."""
from pathlib import Path

import numpy as np
import pytest

from tests.cli_runner import thermoplc
from tests.golden_models import batch_csvs
from thermoplc import api
from thermoplc.base.errors import UserError
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
    plan = api.FitPlan(probe=True, probe_every=45, resample_s=20.0)
    model = api.fit([api.read_table(folder / "twin.csv")], request, plan=plan)
    assert model.resample is not None and model.sample_period_s == 20.0
    assert model.to_json().encode() == cli


@pytest.mark.parametrize("plan, message", [
    ({"folds": "4"}, "--folds: expected an integer, found '4'"),
    ({"folds": 2.5}, "--folds: expected an integer, found 2.5"),
    ({"folds": 1}, "--folds: expected folds from 2 to 1,000,000, found 1"),
    ({"probe": "no"}, "--probe: expected True or False, found 'no'"),
    ({"held_target": 1}, "--held-target: expected True or False, found 1"),
    ({"probe": True, "probe_every": 0}, "--probe-every: expected a number of calls from 1 to"),
    ({"groups": {"a": [0], "b": [True]}}, "--group-by: expected a mapping of group to run indices"),
    ({"probe": True, "probe_every": "45"}, "--probe-every: expected an integer, found '45'"),
    ({"probe": True, "probe_gate_um": -1.0}, "--probe-gate-um: expected um from 0.1 to 100000, found -1.0"),
    ({"probe": True, "probe_gate_um": float("nan")}, "--probe-gate-um: expected um from 0.1 to 100000, found nan"),
    ({"resample_s": float("nan")}, "--resample: expected the block's cycle in seconds"),
    ({"resample_s": "40"}, "--resample: expected a number, found '40'"),
    ({"groups": [[0], [1]]}, "--group-by: expected a mapping of group to run indices"),
    ({"groups": {"a": ["0"]}}, "--group-by: expected a mapping of group to run indices"),
])
def test_a_plan_the_command_line_would_refuse_is_one_line(plan, message):
    with pytest.raises(UserError) as refused:
        api.FitPlan(**plan)
    assert message in str(refused.value) and "\n" not in str(refused.value)


@pytest.mark.parametrize("request_fields, plan, message", [
    ({"train_until": 18000.0}, {"folds": 3}, "give exactly one of --train-until, --train-rows, --folds, --group-by"),
    ({}, {}, "give exactly one of --train-until, --train-rows, --folds, --group-by (FitRequest.train_until, "
             "train_rows; FitPlan.folds, groups), found none"),
    ({}, {"folds": 3, "groups": {"a": [0], "b": [1, 2]}}, "found --folds and --group-by"),
    ({"train_until": 18000.0}, {"probe_every": 45}, "--probe-every sets the probing schedule of a fused block"),
    ({"train_until": 18000.0}, {"probe_gate_um": 3.0}, "--probe-gate-um sets the gate of a fused block"),
    ({"train_until": 18000.0, "keep_every_run": True}, {}, "--keep-every-run keeps a campaign's runs"),
    ({}, {"groups": {"a": [0, 1, 2], "b": [2]}}, "expected each of the 3 runs (0 to 2) in exactly one group"),
    ({}, {"groups": {"a": [0], "b": [7]}}, "expected each of the 3 runs (0 to 2) in exactly one group"),
    ({}, {"groups": {"a": [0, 1, 2], "b": []}}, "--group-by: group 'b' has no run"),
    ({"train_until": 1e9}, {}, "--train-until 1000000000 leaves no row held out"),
])
def test_a_combination_the_command_line_would_refuse_is_refused_alike(folder, request_fields, plan, message):
    """The reviewer's cases: each wrote a model (groups naming a run twice leaked its rows into the evidence)."""
    paths = [folder / f"run_{k}.csv" for k in range(3)]
    if request_fields.get("train_until") == 1e9 or "keep_every_run" in request_fields:
        paths = paths[:1]
    request = api.FitRequest("mlr", "E_z_um", TEMPS, **request_fields)
    with pytest.raises(UserError) as refused:
        api.fit([api.read_table(p) for p in paths], request, plan=api.FitPlan(**plan))
    assert message in str(refused.value) and "\n" not in str(refused.value)


def test_numpy_run_indices_are_taken():
    plan = api.FitPlan(groups={"cool": np.array([0, 1]), "warm": [np.int64(2)]})
    assert plan.groups == {"cool": [0, 1], "warm": [2]}


def test_a_script_that_imported_numpy_first_is_told_its_fits_may_differ():
    """OpenBLAS picks its kernels when numpy loads; thermoplc pins them only if it is imported
first (thermoplc/__init__.py)."""
    import os
    import subprocess
    import sys
    flags = Path("/proc/cpuinfo").read_text(errors="replace") if Path("/proc/cpuinfo").exists() else ""
    if not ({"avx2", "fma"} <= set(flags.split())):
        pytest.skip("the kernels are pinned on x86-64 CPUs with AVX2 and FMA only")
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    said = [subprocess.run([sys.executable, "-c", first], capture_output=True, text=True, env=env,
                           stdin=subprocess.DEVNULL, check=True).stderr
            for first in ("import numpy, thermoplc", "import thermoplc, numpy")]
    assert "numpy was imported before thermoplc" in said[0] and said[1] == ""
