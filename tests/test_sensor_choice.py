"""Issue 50 item 2: each kind earns its inputs. The ridge weight of a campaign's linear map is chosen
leaving out each run (not on the last third of the pooled runs), and `fit --choose-sensors N` chooses the
block's sensors among the candidates on the training rows alone, again inside every fold."""
import json
import math

import jsonschema
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from thermoplc.base.errors import UserError
from thermoplc.base import ridge
from thermoplc.fitting.crossval import fit_held_out
from thermoplc.fitting.fit import FitRequest
from thermoplc.fitting.sensor_choice import choose, training_rises
from thermoplc.recordings.table import Table, read_table, write_table
from tests.cli_runner import thermoplc
from tests.test_json_output import schema

SENSORS = tuple(f"T{i}" for i in range(8))


def _campaign(runs: int, seed: int, drivers=(2, 5)) -> list[Table]:
    """Runs of 8 sensors: two drive the drift (each with its own heating), the rest follow other heat sources
    or one another; every run starts afresh, so the drift follows the drivers' rises since the run's start."""
    rng = np.random.default_rng(seed)
    tables = []
    for r in range(runs):
        rows = 300
        heat = np.cumsum(rng.normal(0.0, 0.05, (rows, 4)), axis=0)
        temps = np.empty((rows, len(SENSORS)))
        for i in range(len(SENSORS)):
            temps[:, i] = 20.0 + heat[:, i % 4] * (1.0 + 0.1 * i) + rng.normal(0.0, 0.02, rows)
        temps[:, drivers[0]] = 20.0 + heat[:, 0] * 0.3 + np.cumsum(rng.normal(0.0, 0.05, rows))
        temps[:, drivers[1]] = 20.0 + np.cumsum(rng.normal(0.0, 0.05, rows))
        drift = 4.0 * (temps[:, drivers[0]] - temps[0, drivers[0]]) - 2.5 * (temps[:, drivers[1]] - temps[0, drivers[1]])
        columns = {"time_s": np.arange(rows) * 60.0, "E_um": drift + rng.normal(0.0, 0.1, rows),
                   **{name: temps[:, i] for i, name in enumerate(SENSORS)}}
        tables.append(Table(f"run{r + 1}.csv", columns, f"choice:{seed}:{r}", np.arange(2, rows + 2)))
    return tables


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(3, 30), min_size=2, max_size=6), st.integers(1, 5), st.integers(0, 2 ** 31))
def test_leaving_out_each_run_from_sums_equals_refitting_without_it(runs, columns, seed):
    """The sums-of-products shortcut gives, for every weight, the error of the ridge refitted on the other runs
    (least squares where binary32 can resolve it: beyond ridge.CONDITION_LIMIT weight 0 is no candidate)."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(sum(runs), columns)) + rng.normal(size=columns) * 10
    y = x @ rng.normal(size=columns) + rng.normal(size=sum(runs)) + 3.0
    fast = ridge.leave_one_run_out(x, y, runs, ridge.WEIGHTS)
    bounds = np.cumsum([0, *runs])
    resolved = all(ridge.condition(x[np.r_[0:a, b:len(y)]], True) <= ridge.CONDITION_LIMIT
                   for a, b in zip(bounds[:-1], bounds[1:]))
    for weight, found in zip(ridge.WEIGHTS, fast):
        if weight == 0.0 and not resolved:
            continue
        squares = 0.0
        for a, b in zip(bounds[:-1], bounds[1:]):
            others = np.r_[0:a, b:len(y)]
            offset, slopes = ridge.ridge(x[others], y[others], weight)
            squares += float(np.sum((y[a:b] - offset - x[a:b] @ slopes) ** 2))
        assert math.isclose(found, math.sqrt(squares / len(y)), rel_tol=1e-6, abs_tol=1e-9)


def test_a_campaign_chooses_its_ridge_weight_leaving_out_each_run():
    tables = _campaign(5, 1)
    model = fit_held_out(tables, FitRequest("mlr", "E_um", SENSORS, train_until=math.inf), None)
    assert model.fit["ridge_weight_by"] == "leaving out each of 5 runs"
    one = fit_held_out(tables[:1], FitRequest("mlr", "E_um", SENSORS, train_rows=200), None)
    assert "ridge_weight_by" not in one.fit  # one recording: forward validation, its model file unchanged


@pytest.mark.parametrize("runs, seed", [(6, seed) for seed in range(2, 8)] + [(4, 5)])
def test_the_drivers_are_found_among_followers(runs, seed):
    """Two drivers whose difference is the drift: neither needs to lead alone (4 runs of seed 5: T7 leads, and
    forward selection from it never takes T2 and T5), the pairs are all scored."""
    tables = _campaign(runs, seed)
    data = training_rises([t.columns for t in tables], "E_um", SENSORS)
    found = choose(data, SENSORS, 4)
    assert set(found.chosen) == {"T2", "T5"}
    assert set(found.best[1][0]) == {"T2", "T5"} and found.best[1][1] < 0.5 * found.best[0][1]


def test_every_fold_chooses_on_its_own_training_runs(tmp_path):
    """The held-out evidence is of the procedure: each fold's set is the one chosen on its training runs alone
    (two runs whose drift follows other sensors make the folds disagree), and the block reads the set chosen
    on every run."""
    tables = _campaign(4, 3) + _campaign(2, 4, drivers=(1, 6))
    model = fit_held_out(tables, FitRequest("mlr", "E_um", SENSORS, train_until=math.inf, choose_sensors=3), 6)
    folds = model.metrics["cross_validation"]
    assert len(folds) == 6 and all(f["sensors"] for f in folds)
    for k, fold in enumerate(folds):
        others = [t for j, t in enumerate(tables) if j != k]
        alone = choose(training_rises([t.columns for t in others], "E_um", SENSORS), SENSORS, 3)
        assert tuple(fold["sensors"]) == alone.chosen
    assert len({tuple(f["sensors"]) for f in folds}) > 1
    assert [s.column for s in model.signals("temperature")] == list(model.fit["sensor_choice"]["chosen"])


def test_choose_sensors_end_to_end(tmp_path):
    (tmp_path / "runs").mkdir()
    for table in _campaign(4, 5):
        (tmp_path / "runs" / table.path).write_text(write_table(table.columns))
    every = ",".join(SENSORS)
    out = thermoplc("fit", "--data", "runs", "--model", "dlag", "--target", "E_um", "--temps", every,
                    "--choose-sensors", 3, "--folds", 4, "-o", "m.json", "--json", "fit.json", cwd=tmp_path).stdout
    document = json.loads((tmp_path / "fit.json").read_text())
    jsonschema.validate(document, schema("fit"))
    assert document["sensor_choice"]["chosen"] == ["T2", "T5"]
    assert "sensors chosen: T2, T5 of 8 candidates (ridge error leaving out each of 4 training runs" in out
    assert "4 of 4 folds chose the same set on their own training rows" in out
    written = json.loads((tmp_path / "m.json").read_text())
    assert [s["column"] for s in written["inputs"]] == ["T2", "T5"]
    thermoplc("generate", "m.json", "-o", "b.scl", cwd=tmp_path)
    thermoplc("verify", "b.scl", "--model", "m.json", "--data", "runs", cwd=tmp_path)
    auto = thermoplc("fit", "--data", "runs", "--model", "auto", "--target", "E_um", "--temps", every,
                     "--choose-sensors", 3, "--folds", 4, "-o", "a.json", cwd=tmp_path, check=2).stderr
    assert "--choose-sensors is for one kind: --model auto chooses its sensor sets itself" in auto
    zero = thermoplc("fit", "--data", "runs", "--model", "mlr", "--target", "E_um", "--temps", every,
                     "--choose-sensors", 0, "--folds", 4, "-o", "z.json", cwd=tmp_path, check=2).stderr
    assert "--choose-sensors" in zero and not (tmp_path / "z.json").exists()


def test_one_short_recording_cannot_choose():
    table = _campaign(1, 6)[0].head(30)
    with pytest.raises(UserError, match="--choose-sensors: 30 measured training rows; choosing sensors on one "
                                        "recording fits two thirds"):
        fit_held_out([table], FitRequest("mlr", "E_um", SENSORS, train_rows=30, choose_sensors=2), None)


def test_auto_on_a_campaign_ranks_the_evidence_it_writes(tmp_path):
    """Issue 50 item 4: each kind chooses its sensors inside every fold, the ranking is by that held-out error
    (--folds 5 of 5 runs: each run left out), and the model written carries the very figure it was ranked by."""
    (tmp_path / "runs").mkdir()
    for table in _campaign(5, 7):
        (tmp_path / "runs" / table.path).write_text(write_table(table.columns))
    out = thermoplc("fit", "--data", "runs", "--model", "auto", "--target", "E_um", "--temps", ",".join(SENSORS),
                    "--folds", 5, "-o", "a.json", "--json", "a.fit.json", cwd=tmp_path).stdout
    assert "leave-one-run-out cross-validation over 5 runs" in out
    assert "each kind chose its sensors among --temps itself, again inside every fold (at most: " in out
    written = json.loads((tmp_path / "a.json").read_text())
    ranking = [c for c in written["metrics"]["auto_ranking"] if "rmse_um" in c]
    accepted = [c["rmse_um"] for c in ranking if not c["generate_refuses"]]
    assert accepted == sorted(accepted) and len(ranking) >= 5
    assert written["metrics"]["held_out"]["rmse_um"] == ranking[0]["rmse_um"]
    assert written["kind"] == ranking[0]["kind"] and len(written["metrics"]["cross_validation"]) == 5
    assert all(f["sensors"] for f in written["metrics"]["cross_validation"])
    mlr = [set(c["sensors"]) for c in ranking if c["kind"] == "mlr"]
    assert mlr.count({"T2", "T5"}) == 1 and mlr.count(set(SENSORS)) == 1  # chosen in the folds, and shrunk on all


def test_a_still_sensor_is_never_chosen_and_the_block_reads_the_order_of_temps():
    tables = _campaign(4, 8)
    for table in tables:
        table.columns["T_flat"] = np.full(len(table.columns["E_um"]), 21.0)
    candidates = ("T_flat", *SENSORS[::-1])
    found = choose(training_rises([t.columns for t in tables], "E_um", candidates), candidates, 2)
    assert found.chosen == ("T5", "T2") and found.still == ("T_flat",)  # T5 before T2, as --temps names them
    assert found.log()["not_moving"] == ["T_flat"]
    model = fit_held_out(tables, FitRequest("mlr", "E_um", candidates, train_until=math.inf, choose_sensors=2), 4)
    assert [s.column for s in model.signals("temperature")] == ["T5", "T2"]


def test_the_best_set_of_n_is_searched_past_n(tmp_path):
    """A floating step back from a larger set finds a better set of 3 than forward reaches at 3 (twin seed 3:
    T_bearing, T_struct, T_env 0.89 um against T_motor, T_struct, T_env 0.82 um)."""
    thermoplc("twin", "--runs", 5, "--hours", 6, "--dt", 60, "--seed", 3, "-o", "runs", cwd=tmp_path)
    tables = [read_table(path) for path in sorted((tmp_path / "runs").glob("run_*.csv"))]
    candidates = ("T_env", "T_motor", "T_bearing", "T_struct", "T_base")
    data = training_rises([t.columns for t in tables], "E_z_um", candidates)
    three = choose(data, candidates, 3)
    assert three.chosen == ("T_env", "T_motor", "T_struct")
    assert dict((len(s), e) for s, e in choose(data, candidates, 5).best)[3] == three.best[-1][1]


def test_auto_on_two_runs_ranks_sensor_sets_as_on_one_recording(tmp_path):
    """Two runs: each fold would choose on one run's last third; auto ranks its sensor sets instead."""
    (tmp_path / "runs").mkdir()
    for table in _campaign(2, 10):
        (tmp_path / "runs" / table.path).write_text(write_table(table.columns))
    out = thermoplc("fit", "--data", "runs", "--model", "auto", "--target", "E_um", "--temps", ",".join(SENSORS),
                    "--folds", 2, "-o", "a.json", cwd=tmp_path).stdout
    assert "chose its sensors among --temps itself" not in out and "writing the best:" in out
