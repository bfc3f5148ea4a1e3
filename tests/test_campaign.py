"""Campaigns (issue 37): runs that each start a fresh block, cross-validation by run and by group,
probed targets, mixed sample periods refused, a campaign verified run by run, the fit report."""
import math
from pathlib import Path

import numpy as np
import pytest

from tests.cli_runner import thermoplc
from thermoplc.machines.campaign import plan, simulate_run
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.models.modelfile import load_model
from thermoplc.models.safety import Limits
from thermoplc.recordings.table import Table, read_table, write_table
from thermoplc.verifier.replays.replay import block_columns, load_block

COMMON = ("--target", "E_z_um", "--temps", "T_motor,T_bearing,T_struct")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """Six runs of 4 h at 60 s of the cascade machine, drift probed every 30 min and held."""
    folder = tmp_path_factory.mktemp("campaign")
    thermoplc("twin", "--runs", 6, "--hours", 4, "--dt", 60, "--seed", 5, "--probe-minutes", 30, "-o", "runs",
              cwd=folder)
    return folder / "runs"


def _runs(count: int = 2) -> list[Table]:
    tables = []
    for p in plan(count, 11):
        columns = simulate_run("cascade", p, 4.0, 60.0, 0.0)
        tables.append(Table(f"run{p.index}.csv", columns, str(p.seed), np.arange(2, len(columns["time_s"]) + 2)))
    return tables


def _replay(block: str, table: Table, output: str) -> np.ndarray:
    _, replayer = load_block(block, "interp")
    return np.asarray(replayer.replay(block_columns(replayer.inputs, table, None, block), table.rows,
                                      outputs=(output,))[output], np.float32)


@pytest.mark.parametrize("kind", ["mlr", "dlag", "gm1n", "kalman", "lumped"])
def test_a_reset_replay_equals_a_fresh_block_per_run(tmp_path, kind):
    """Run 1 then run 2 with Reset TRUE on run 2's first call: from the call the rate limiter has moved the
    output onto the model's value, every bit equals a block started fresh on run 2 (docs: Reset starts
    the block as a new instance would, except the outputs, which the rate limiter moves)."""
    first, second = _runs()
    request = FitRequest(kind=kind, target="E_z_um", temps=("T_motor", "T_bearing"), speed="n_rpm", ambient="T_env",
                         train_until=math.inf, settings={"population": 8, "generations": 3})
    model = fit([first, second], request)
    (tmp_path / "m.json").write_text(model.to_json())
    thermoplc("generate", "m.json", "-o", "b.st", "--dialect", "iec", "--accept-unvalidated", cwd=tmp_path)
    block = str(tmp_path / "b.st")
    fresh = _replay(block, second, model.target.name)
    joined_columns = {c: np.concatenate([first.columns[c], second.columns[c]]) for c in first.columns}
    joined_columns["Reset"] = np.zeros(first.rows + second.rows)
    joined_columns["Reset"][first.rows] = 1.0
    joined = Table("joined.csv", joined_columns, "j", np.arange(2, first.rows + second.rows + 2))
    after = _replay(block, joined, model.target.name)[first.rows:]
    same = np.flatnonzero(after.view(np.uint32) == fresh.view(np.uint32))
    assert len(same), "the output never meets the fresh block's"
    meets = int(same[0])
    assert np.array_equal(after[meets:].view(np.uint32), fresh[meets:].view(np.uint32))
    step = Limits.for_model(model).max_step  # the rate limit, from the recording (models/envelope.py)
    rate = float(np.max(np.abs(np.diff(fresh)))) or 1.0
    assert meets <= math.ceil(abs(float(after[0]) - float(fresh[0])) / step) + 2
    assert rate < step + 1e-3


def test_every_kind_fits_a_campaign_each_run_from_its_own_start():
    """The same run fitted alone or as the only run gives the same coefficients; two runs pool their rows,
    and the rises of run 2 are taken from run 2's first row (not from run 1's)."""
    first, second = _runs()
    request = FitRequest(kind="mlr", target="E_z_um", temps=("T_motor", "T_bearing"), train_until=math.inf)
    both = fit([first, second], request)
    moved = Table(second.path, {**second.columns, **{c: second.columns[c] + 7.0 for c in ("T_motor", "T_bearing")}},
                  second.sha256, second.lines)
    shifted = fit([first, moved], request)  # an offset of run 2's sensors vanishes in its rises
    # (x + 7) - (x0 + 7) is x - x0 to the last bit of float64 only mostly: the block's binary32 coefficients agree
    assert {k: c.f32 for k, c in shifted.coefficients.items()} == {k: c.f32 for k, c in both.coefficients.items()}
    assert all(math.isclose(c.f64, both.coefficients[k].f64, rel_tol=1e-12) for k, c in shifted.coefficients.items())
    assert both.metrics["train"]["rows"] == first.rows + second.rows


def test_leave_one_run_out_reports_every_run_beside_no_compensation(campaign, tmp_path):
    out = thermoplc("fit", "--data", campaign, "--model", "mlr", *COMMON, "--held-target", "--folds", 6, "-o",
                    tmp_path / "m.json", cwd=tmp_path).stdout
    assert "leave-one-run-out cross-validation over 6 runs" in out
    assert "probed target: errors on the measured rows only" in out
    model = load_model(str(tmp_path / "m.json"))
    runs = model.metrics["runs"]
    assert [r["run"] for r in runs] == [f"run_{k:03d}.csv" for k in range(1, 7)]
    assert model.metrics["held_out"]["rows"] == 6 * 9  # 4 h probed every 30 min: 9 probings a run, the first at 0
    assert model.metrics["held_out"]["rmse_um"] < 0.5 * model.metrics["held_out"]["zero_rmse_um"]


def test_a_probed_target_with_empty_cells_uses_the_measured_rows_only(campaign, tmp_path):
    """Empty cells between probings read as no measurement; the fit equals the held form's."""
    for k in range(1, 7):
        table = read_table(campaign / f"run_{k:03d}.csv")
        values = table.columns["E_z_um"].copy()
        changed = np.r_[True, values[1:] != values[:-1]]
        text = write_table(table.columns).splitlines()
        column = text[0].split(",").index("E_z_um")
        lines = [text[0]] + [",".join("" if c == column and not changed[r] else cell
                                      for c, cell in enumerate(row.split(",")))
                             for r, row in enumerate(text[1:])]
        (tmp_path / f"run_{k:03d}.csv").write_text("\n".join(lines) + "\n")
    data = [x for k in range(1, 7) for x in ("--data", f"run_{k:03d}.csv")]
    thermoplc("fit", *data, "--model", "mlr", *COMMON, "--folds", 6, "-o", "empty.json", cwd=tmp_path)
    thermoplc("fit", "--data", campaign, "--model", "mlr", *COMMON, "--held-target", "--folds", 6, "-o", "held.json",
              cwd=tmp_path)
    empty, held = load_model(str(tmp_path / "empty.json")), load_model(str(tmp_path / "held.json"))
    assert empty.coefficients == held.coefficients
    assert empty.metrics["held_out"]["rows"] == held.metrics["held_out"]["rows"] == 54
    blank = thermoplc("fit", "--data", "run_001.csv", "--model", "mlr", "--target", "T_base", "--temps", "E_z_um",
                      "--train-until", 3600, "-o", "x.json", cwd=tmp_path, check=2)
    assert "run_001.csv:3:" in blank.stderr and "column 'E_z_um': expected a number, found ''" in blank.stderr


def test_grouped_folds_fit_cool_runs_and_predict_warm_ones(campaign, tmp_path):
    out = thermoplc("fit", "--runs", campaign / "runs.csv", "--model", "mlr", *COMMON, "--held-target",
                    "--group-by", "hall", "-o", "g.json", cwd=tmp_path).stdout
    model = load_model(str(tmp_path / "g.json"))
    assert sorted(f["label"] for f in model.metrics["cross_validation"]) == ["cool", "warm"]
    assert len(model.metrics["runs"]) == 6 and "leave-one-group-out cross-validation over 2 groups" in out
    assert "run_001.csv (" in out  # each run's line under the grouped folds
    wrong = thermoplc("fit", "--runs", campaign / "runs.csv", "--model", "mlr", *COMMON, "--group-by", "colour",
                      "-o", "x.json", cwd=tmp_path, check=2)
    assert "--group-by colour: not a column of the runs table" in wrong.stderr and "hall" in wrong.stderr


def test_runs_at_another_sample_period_are_refused_by_file(tmp_path):
    thermoplc("twin", "--hours", 2, "--dt", 60, "--seed", 1, "-o", "a.csv", cwd=tmp_path)
    thermoplc("twin", "--hours", 2, "--dt", 30, "--seed", 2, "-o", "b.csv", cwd=tmp_path)
    refused = thermoplc("fit", "--data", "a.csv", "--data", "b.csv", "--model", "mlr", *COMMON, "--folds", 2,
                        "-o", "m.json", cwd=tmp_path, check=2)
    assert "b.csv: sampled every 30 s, but a.csv every 60 s" in refused.stderr
    assert not (tmp_path / "m.json").exists()


def test_verify_replays_each_run_from_a_fresh_block_and_gives_one_verdict(campaign, tmp_path):
    thermoplc("fit", "--data", campaign, "--model", "dlag", *COMMON, "--held-target", "--folds", 3, "-o", "d.json",
              cwd=tmp_path)
    thermoplc("generate", "d.json", "-o", "d.scl", "--accept-unvalidated", cwd=tmp_path)
    ok = thermoplc("verify", "d.scl", "--model", "d.json", "--runs", campaign / "runs.csv", cwd=tmp_path).stdout
    assert ok.count(" bit-exact ") == 6 and "bit-exact: every run reproduces the reference (6 runs" in ok
    clamp = Limits.for_model(load_model(tmp_path / "d.json")).max_output  # from the campaign (models/envelope.py)
    assert f"safety limits read from the block: outputs within +-{clamp:g}" in ok  # what the reference was judged in
    text = (tmp_path / "d.scl").read_text()
    edited = text.replace("c_beta0 : Real := ", "c_beta0 : Real := 1", 1)
    assert edited != text
    (tmp_path / "e.scl").write_text(edited)
    bad = thermoplc("verify", "e.scl", "--model", "d.json", "--data", campaign, cwd=tmp_path, check=1).stdout
    assert "NOT bit-exact (6 NOT bit-exact; 6 runs" in bad


def test_runs_tables_that_cannot_be_read_name_the_line(tmp_path):
    (tmp_path / "r.csv").write_text("name,hall\nx.csv,cool\n")
    no_file = thermoplc("fit", "--runs", "r.csv", "--model", "mlr", *COMMON, "--folds", 2, "-o", "m.json",
                        cwd=tmp_path, check=2)
    assert "r.csv:1: no 'file' column" in no_file.stderr
    (tmp_path / "r.csv").write_text("file,hall\nx.csv,cool\nx.csv,warm\n")
    twice = thermoplc("fit", "--runs", "r.csv", "--model", "mlr", *COMMON, "--folds", 2, "-o", "m.json",
                      cwd=tmp_path, check=2)
    assert "r.csv:3: x.csv is listed twice (first on line 2)" in twice.stderr
    (tmp_path / "empty").mkdir()
    folder = thermoplc("fit", "--data", "empty", "--model", "mlr", *COMMON, "--folds", 2, "-o", "m.json",
                       cwd=tmp_path, check=2)
    assert "empty: a folder with no recordings in it" in folder.stderr


def test_twin_campaigns_are_reproducible_and_say_what_each_run_is(tmp_path):
    for name in ("a", "b"):
        thermoplc("twin", "--runs", 3, "--hours", 1, "--dt", 60, "--seed", 9, "--effect", "slow_structure",
                  "--effect-runs", "2", "-o", name, cwd=tmp_path)
    for file in ("runs.csv", "run_001.csv", "run_002.csv", "run_003.csv"):
        assert (tmp_path / "a" / file).read_bytes() == (tmp_path / "b" / file).read_bytes()
    rows = (tmp_path / "a" / "runs.csv").read_text().splitlines()
    assert rows[0] == "file,hall_air_C,hall,air,start,seed,effects"
    assert rows[2].endswith(",slow_structure") and rows[1].endswith(",none")
    again = thermoplc("twin", "--runs", 3, "--hours", 1, "-o", "a", cwd=tmp_path, check=2)
    assert "a new or empty folder" in again.stderr


def test_fit_report_shows_every_run_and_the_folds(campaign, tmp_path):
    out = thermoplc("fit", "--data", campaign, "--model", "mlr", *COMMON, "--held-target", "--folds", 6,
                    "-o", "m.json", "--report", "rep", cwd=tmp_path).stdout
    assert "wrote rep/index.html" in out
    page = (tmp_path / "rep" / "index.html").read_text()
    assert page.count("<img") == 7 and "Folds" in page and "hall_air_C" in page  # 6 runs and the summary
    pngs = sorted(p.name for p in (tmp_path / "rep").glob("run_*.png"))
    runs = sorted(p.name for p in campaign.glob("run_*.csv"))
    assert pngs == [f"{Path(r).stem}.png" for r in runs]  # run_001.csv is run_001.png: its number once
    assert all((tmp_path / "rep" / name).read_bytes()[:4] == b"\x89PNG" for name in pngs)
    for k, name in enumerate(pngs, start=1):  # in table order, each with its number and the block's error beside none
        assert f'<h3>{k}. ' in page and f'src="{name}"' in page
    assert "<code>thermoplc fit --data" in page and "E_z_um (µm)" in page and "no compensation" in page
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("mine")
    refused = thermoplc("fit", "--data", campaign, "--model", "mlr", *COMMON, "--held-target", "--folds", 6,
                        "-o", "m2.json", "--report", "mine", cwd=tmp_path, check=2)
    assert "is not a report thermoplc wrote" in refused.stderr and not (tmp_path / "m2.json").exists()


@pytest.mark.parametrize("kind", ["gm0n", "gm1n"])
def test_grey_kinds_choose_rises_on_a_campaign_and_stay_bit_exact(campaign, tmp_path, kind):
    """A campaign whose drift is zeroed at each run's start and whose hall air moves: the grey kinds take
    the rises since each run's start with a unit sequence (b_0, the offset), beat no compensation held out,
    and the block, the compiled reference and the Python reference agree bit for bit."""
    from thermoplc.base import compiled as kernels
    from thermoplc.models.reference import model_inputs, predict
    thermoplc("fit", "--data", campaign, "--model", kind, *COMMON, "--held-target", "--folds", 6, "-o", "g.json",
              cwd=tmp_path)
    model = load_model(str(tmp_path / "g.json"))
    assert model.settings["rises"] is True and "b_0" in model.coefficients
    held = model.metrics["held_out"]
    assert held["rmse_um"] < 0.5 * held["zero_rmse_um"]
    table = read_table(campaign / "run_002.csv")
    inputs = model_inputs(model, table)
    with kernels.reference("slow"):
        slow = predict(model, inputs, "f32")["E_z_um"]
    with kernels.reference("fast"):
        fast = predict(model, inputs, "f32")["E_z_um"]
    assert np.array_equal(slow.view(np.uint32), fast.view(np.uint32))
    thermoplc("generate", "g.json", "-o", "g.st", "--dialect", "iec", "--accept-unvalidated", cwd=tmp_path)  # 54 probings
    for engine in ("interp", "fast"):
        out = thermoplc("verify", "g.st", "--model", "g.json", "--data", campaign, "--engine", engine,
                        cwd=tmp_path).stdout
        assert "bit-exact: every run reproduces the reference (6 runs" in out
