"""Sensor selection (papers 001 and 002) and its hand-over to fit."""
import numpy as np
import pytest

from tests.test_cli import thermoplc
from thermoplc.models.selection import fuzzy_cluster, grey_relational_grades, select_sensors


def test_duplicated_sensors_fall_into_one_group():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 10, 500)
    slow, fast = 20 + 5 * (1 - np.exp(-t / 5)), 25 + np.sin(t)  # temperatures, degC
    columns = {"a": slow, "a_copy": slow + rng.normal(0, 1e-3, 500), "b": fast, "b_copy": fast * 1.01}
    target = 3 * slow + fast
    for method in ("fcm-grey", "grey-cluster"):
        selection = select_sensors(columns, target, method, threshold=0.9, max_groups=2)
        groups = {frozenset(g) for g in selection.groups}
        assert frozenset({"a", "a_copy"}) in groups, (method, selection.groups)
        assert len(selection.chosen) == len(selection.groups)


def test_grey_relational_grade_prefers_the_similar_series():
    t = np.linspace(0, 1, 100)
    grades = grey_relational_grades(np.array([t ** 2, 1 - t]), t)
    assert grades[0] > grades[1]


def test_fuzzy_cluster_respects_the_group_limit():
    rng = np.random.default_rng(1)
    groups, _, _ = fuzzy_cluster(rng.normal(size=(8, 200)).cumsum(axis=1), max_groups=3)
    assert 2 <= len(groups) <= 3


@pytest.mark.parametrize("method", ["fcm-grey", "grey-cluster"])
def test_select_sensors_cli_feeds_fit(tmp_path, method):
    thermoplc("twin", "--hours", 6, "--seed", 2, "-o", "twin.csv", cwd=tmp_path)
    out = thermoplc("select-sensors", "--data", "twin.csv", "--target", "E_z_um", "--method", method,
                    "--candidates", "T_motor,T_bearing,T_struct,T_base,T_env", "-o", "chosen.txt", cwd=tmp_path).stdout
    assert "group 1:" in out and "chosen:" in out
    header, chosen = (tmp_path / "chosen.txt").read_text().strip().splitlines()
    assert header.startswith("# thermoplc select-sensors")
    assert chosen and set(chosen.split(",")) <= {"T_motor", "T_bearing", "T_struct", "T_base", "T_env"}
    fitted = thermoplc("fit", "--data", "twin.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "@chosen.txt",
                       "--train-until", 10800, "-o", "m.json", cwd=tmp_path).stdout
    assert "prediction (held out)" in fitted
