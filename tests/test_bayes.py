"""Paper 004's Bayesian network: discretisation, the block's lookup, and every table entry checked."""
import numpy as np

from tests.conftest import fit_small
from tests.test_piecewise import table_mutants
from thermoplc.generator.lower import lower
from thermoplc.generator.printer import render
from thermoplc.models.bayes import configuration, interval
from thermoplc.verifier.replay import verify_against_model


def test_intervals_and_configuration_index():
    edges = [1.0, 2.0, 3.0]
    assert interval(np.array([-5, 0.99, 1.0, 2.5, 3.0, 99]), edges).tolist() == [0, 0, 1, 2, 3, 3]
    assert configuration([np.array([1, 3]), np.array([2, 0])], [4, 5]).tolist() == [1 + 4 * 2, 3]


def test_every_table_entry_of_the_bayes_block_is_checked(twin_table, tmp_path):
    model = fit_small(twin_table, "bayes")
    model_path = tmp_path / "bayes.json"
    model_path.write_text(model.to_json())
    text = render(lower(model))
    (tmp_path / "bayes.scl").write_text(text)
    assert verify_against_model(str(tmp_path / "bayes.scl"), model, str(model_path), twin_table).ok
    entries = 0
    for entry, mutant in table_mutants(text):
        (tmp_path / "mutant.scl").write_text(mutant)
        report = verify_against_model(str(tmp_path / "mutant.scl"), model, str(model_path), twin_table)
        assert not report.ok, f"{entry} changed by one ULP went unnoticed"
        assert any(e.startswith(entry) for e in report.constant_errors)
        entries += 1
    expected = sum(k - 1 for k in model.settings["intervals"]) + model.settings["configurations"]
    assert entries == expected


def test_an_unseen_configuration_answers_as_the_nearest_seen_one():
    from thermoplc.models.bayes import fit_rises, predict_rises
    rises = np.array([[0.0, 0.0], [0.1, 0.0], [3.9, 0.0], [4.0, 4.0]])
    target = np.array([1.0, 1.0, 9.0, 20.0])
    nearest, settings, _ = fit_rises(rises, target, 4, 1.0, unseen="nearest")
    frequent, _, _ = fit_rises(rises, target, 4, 1.0, unseen="frequent")
    probe = np.array([[3.5, 1.5]])  # never seen: one interval step from (3.9, 0) and further from the others
    assert predict_rises(nearest, settings, probe)[0] == 9.5
    assert predict_rises(frequent, settings, probe)[0] == 1.5  # the interval most frequent overall


def test_time_parent_over_repeated_runs_is_bit_exact(tmp_path):
    from tests.cli_runner import thermoplc
    from thermoplc.recordings.table import write_table
    from thermoplc.machines.cascade import simulate
    rng = np.random.default_rng(4)
    runs = []
    for r in range(8):
        path = tmp_path / f"run{r}.csv"
        path.write_text(write_table(simulate(2.5, seed=700 + r, dt=60.0, constant_rpm=float(rng.uniform(2600, 3400)),
                                             ambient_start=float(rng.uniform(18.0, 24.0)))))
        runs.append(path.name)
    cli = lambda *a: thermoplc(*a, cwd=tmp_path, check=None)
    data = [x for name in runs[:7] for x in ("--data", name)]
    fitted = cli("fit", *data, "--model", "bayes", "--target", "E_z_um", "--temps", "T_env,T_bearing,T_motor",
                 "--time-bins", "4", "--train-until", "99999", "-o", "bt.json")
    assert fitted.returncode == 0, fitted.stderr
    assert cli("generate", "bt.json", "-o", "bt.st", "--dialect", "iec", "--accept-unvalidated").returncode == 0
    verified = cli("verify", "bt.st", "--model", "bt.json", "--data", runs[7])
    assert verified.returncode == 0 and "bit-exact" in verified.stdout, verified.stdout + verified.stderr
    plain = cli("fit", *data, "--model", "bayes", "--target", "E_z_um", "--temps", "T_env", "--train-until", "99999",
                "-o", "plain.json")  # runs without the time parent: every kind fits a campaign (issue 37)
    assert plain.returncode == 0 and "fitted bayes on 7 runs" in plain.stdout, plain.stderr
