"""Sensor selection (papers 001 and 002) and its hand-over to fit."""
import numpy as np
import pytest

from tests.cli_runner import thermoplc
from thermoplc.fitting.selection import fuzzy_cluster, grey_relational_grades, select_sensors


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


def test_select_sensors_and_fit_refuse_the_answer_in_disguise(tmp_path):
    """The issue's leak: default candidates were every column; now temperatures only, and the target under
    another name, a column that alone predicts it, or a non-temperature given as one, is refused."""
    import numpy as np
    from tests.cli_runner import thermoplc
    from thermoplc.recordings.table import read_table, write_table
    thermoplc("twin", "--hours", 12, "--seed", 3, "-o", "twin.csv", cwd=tmp_path)
    out = thermoplc("select-sensors", "--data", "twin.csv", "--target", "E_z_um", "--train-until", 21600,
                    cwd=tmp_path).stdout
    chosen = out.splitlines()[-1].split(": ", 1)[1].split(",")
    assert chosen and all(c.startswith("T_") for c in chosen), out
    assert "E_z_true_um" not in out and "v_feed" not in out and "tool_length" not in out and "2161 rows" in out
    columns = dict(read_table(tmp_path / "twin.csv").columns)
    columns["T_probe"] = 20.0 + 0.05 * columns["E_z_um"]  # a scaled copy of the target, named like a temperature
    # the target 5 min late: it does not carry the target's noise at the same call, so it is no copy
    columns["T_late"] = np.concatenate([np.full(30, 25.0), 25.0 + 0.1 * columns["E_z_um"][:-30]])
    (tmp_path / "leaky.csv").write_text(write_table(columns))
    cases = [
        (("select-sensors", "--data", "twin.csv", "--target", "E_z_um", "--candidates", "T_motor,E_z_true_um"),
         "--candidates column 'E_z_true_um' is named like the target 'E_z_um'"),
        (("select-sensors", "--data", "twin.csv", "--target", "E_z_um", "--candidates", "T_motor,v_feed_mm_min"),
         "column 'v_feed_mm_min': 2000 cannot be a temperature"),
        (("select-sensors", "--data", "leaky.csv", "--target", "E_z_um", "--candidates", "T_motor,T_probe"),
         "--candidates column 'T_probe' is a copy of the target 'E_z_um' (an affine map"),
        (("fit", "--data", "twin.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,v_feed_mm_min",
          "--train-until", 21600, "-o", "m.json"), "cannot be a temperature (--temps;"),
        (("fit", "--data", "twin.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,E_z_true_um",
          "--train-until", 21600, "-o", "m.json"), "--temps column 'E_z_true_um' is named like the target"),
        (("fit", "--data", "leaky.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_probe",
          "--train-until", 21600, "-o", "m.json"), "--temps column 'T_probe' is a copy of the target"),
        (("fit", "--data", "twin.csv", "--model", "kalman", "--target", "E_z_um", "--temps", "T_motor",
          "--speed", "E_z_true_um", "--ambient", "T_env", "--train-until", 21600, "-o", "m.json"),
         "--speed column 'E_z_true_um' is named like the target"),
    ]
    out = thermoplc("select-sensors", "--data", "leaky.csv", "--target", "E_z_um", cwd=tmp_path).stdout
    assert "left out T_probe: is a copy of the target" in out and "left out T_late" not in out
    assert "T_probe" not in out.splitlines()[-1]
    for argv, message in cases:
        result = thermoplc(*argv, cwd=tmp_path, check=2)
        assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1, result.stderr
        assert not (tmp_path / "m.json").exists()
