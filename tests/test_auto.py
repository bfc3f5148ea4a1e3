"""fit --model auto: every applicable kind ranked by held-out error, the best written."""
import json
import re

import pytest

from tests.cli_runner import thermoplc


def _ranked(stdout: str) -> list[tuple[str, float]]:
    return [(m.group(2), float(m.group(3))) for m in re.finditer(r"^  (\d+)\s+(\w+)\s+\S+(?: --\S+ \S+)*\s+([\d.]+)", stdout, re.M)]


def test_auto_ranks_the_kinds_the_roles_allow_and_writes_the_first(tmp_path):
    thermoplc("twin", "--hours", 6, "--seed", 8, "-o", "t.csv", cwd=tmp_path)
    result = thermoplc("fit", "--data", "t.csv", "--model", "auto", "--target", "E_z_um", "--temps",
                       "T_motor,T_bearing", "--train-until", 14400, "-o", "a.json", cwd=tmp_path)
    ranked = _ranked(result.stdout)
    kinds = [k for k, _ in ranked]
    assert "kalman" not in result.stdout and "lumped" not in kinds  # no --speed, --ambient: not applicable
    assert set(kinds) | set(re.findall(r"^  -\s+(\w+)", result.stdout, re.M)) == {"mlr", "dlag", "gm0n", "gm1n",
                                                                                    "bayes", "bpnn"}
    assert [r for _, r in ranked] == sorted(r for _, r in ranked)
    model = json.loads((tmp_path / "a.json").read_text())
    assert model["kind"] == kinds[0] and model["metrics"]["held_out"]["rmse_um"] == pytest.approx(ranked[0][1], abs=5e-4)
    assert f"writing the best: {kinds[0]} on T_motor,T_bearing" in result.stdout


@pytest.mark.slow  # eight kinds, three folds each, a genetic algorithm among them: about 25 s
def test_auto_picks_the_lumped_model_on_a_machine_made_of_lumped_masses(tmp_path):
    thermoplc("twin", "--hours", 24, "--seed", 11, "-o", "t.csv", cwd=tmp_path)
    result = thermoplc("fit", "--data", "t.csv", "--model", "auto", "--target", "E_z_um", "--temps",
                       "T_motor,T_bearing", "--speed", "n_rpm", "--ambient", "T_env", "--folds", 3, "-o", "a.json",
                       cwd=tmp_path)
    ranked = _ranked(result.stdout)
    # two sensor sets (forward selection's first sensor, both): 5 closed-form kinds on each, 3 iterative on the best,
    # and bayes's ridge parent and bpnn's ridge skip path on both sensors (mlr and dlag on both were among the sets)
    assert len(ranked) + result.stdout.count("refused:") == 15
    assert ranked[0][0] == "lumped" and ranked[0][1] < 0.5 * ranked[1][1]
    assert json.loads((tmp_path / "a.json").read_text())["kind"] == "lumped"
    thermoplc("generate", "a.json", "-o", "a.scl", cwd=tmp_path)  # the best passes the acceptance rule


def test_ga_operators_reach_the_bpnn_fit_from_the_command_line(tmp_path):
    thermoplc("twin", "--hours", 4, "--seed", 5, "-o", "t.csv", cwd=tmp_path)
    methods = {}
    for operators in ("paper002", "paper000"):
        thermoplc("fit", "--data", "t.csv", "--model", "bpnn", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
                  "--train-until", 7200, "--generations", 4, "--population", 8, "--ga-operators", operators,
                  "-o", f"{operators}.json", cwd=tmp_path)
        methods[operators] = json.loads((tmp_path / f"{operators}.json").read_text())["fit"]["method"]
    assert "single-point crossover" in methods["paper002"] and "Gaussian mutation" in methods["paper000"]
    assert thermoplc("fit", "--data", "t.csv", "--model", "bpnn", "--target", "E_z_um", "--temps", "T_motor",
                     "--train-until", 7200, "--ga-operators", "roulette", "-o", "x.json", cwd=tmp_path,
                     check=2).stderr.count("invalid choice") == 1


BAD_TEMPS = {
    "a typo": ("T_motor,T_typo", "t.csv: no column 'T_typo'"),
    "the target": ("T_motor,E_z_um", "--temps E_z_um: the column is the target (--target)"),
    "the time column": ("T_motor,time_s", "--temps time_s: the column is the time column (--time)"),
    "the --speed column": ("T_motor,n_rpm", "--temps n_rpm: the column is the --speed input"),
    "a duplicate": ("T_motor,T_bearing,T_motor", "--temps: column 'T_motor' is given twice"),
    "a copy of the target": ("T_motor,E_z_true_um", "--temps column 'E_z_true_um' is named like the target"),
}


@pytest.fixture(scope="module")
def twin_two_hours(tmp_path_factory):
    folder = tmp_path_factory.mktemp("auto_temps")
    thermoplc("twin", "--hours", 2, "--seed", 8, "-o", "t.csv", cwd=folder)
    return folder


@pytest.mark.parametrize("case", BAD_TEMPS)
def test_auto_refuses_what_every_kind_refuses_before_it_fits_anything(twin_two_hours, case):
    """Issue 38 item 4: auto dropped a bad --temps column and wrote a smaller model (exit 0) where mlr exited 2."""
    temps, message = BAD_TEMPS[case]
    for kind in ("kalman", "auto"):  # a kind that reads --speed and --ambient (mlr refuses them, issue 60)
        result = thermoplc("fit", "--data", "t.csv", "--model", kind, "--target", "E_z_um", "--temps", temps,
                           "--speed", "n_rpm", "--ambient", "T_env", "--train-rows", 400, "-o", f"{kind}.json",
                           cwd=twin_two_hours, check=2)
        assert message in result.stderr and result.stdout == "", (kind, result.stderr)
        assert len(result.stderr.strip().splitlines()) == 1 and not (twin_two_hours / f"{kind}.json").exists()


def test_auto_fits_bayes_ridge_parent_without_the_bins_given_for_the_other_bayes(tmp_path):
    """`--bins` reaches the temperature-parent bayes candidate; the ridge-parent one does not read it and is
    fitted without it, not refused (and the option is not carried back in by the request's old keywords)."""
    thermoplc("twin", "--hours", 6, "--seed", 8, "-o", "t.csv", cwd=tmp_path)
    result = thermoplc("fit", "--data", "t.csv", "--model", "auto", "--target", "E_z_um", "--temps",
                       "T_motor,T_bearing", "--train-until", 14400, "--bins", 12, "-o", "a.json", cwd=tmp_path)
    assert re.search(r"^  \d+\s+bayes\s+T_motor,T_bearing --parents ridge\s+[\d.]+", result.stdout, re.M), result.stdout
    assert "refused" not in result.stdout
    ranking = json.loads((tmp_path / "a.json").read_text())["metrics"]["auto_ranking"]
    assert sorted(map(str, (r["options"] for r in ranking if "options" in r))) == [
        str({"--parents": "ridge"}), str({"--skip": "ridge"})]
