"""The leak rule refuses what is not a temperature (the target or a copy of it), never a good sensor."""
import numpy as np
import pytest

from tests.cli_runner import thermoplc
from thermoplc.machines.cascade import simulate
from thermoplc.fitting.leaks import leak_reason
from thermoplc.recordings.table import write_table


@pytest.fixture(scope="module")
def recording():
    """A cascade day whose displacement is linear in two measured temperatures (paper 000's class)."""
    columns = dict(simulate(24, seed=4))
    rng = np.random.default_rng(4)
    motor, bearing = np.asarray(columns["T_motor"]), np.asarray(columns["T_bearing"])
    columns["E_z_um"] = 8.0 * (motor - motor[0]) + 3.0 * (bearing - bearing[0]) + rng.normal(0.0, 0.5, len(motor))
    return columns


def test_a_sensor_that_predicts_the_target_through_physics_is_accepted(recording):
    motor, target = np.asarray(recording["T_motor"]), recording["E_z_um"]
    assert np.corrcoef(motor, target)[0, 1] ** 2 > 0.995  # what the old rule refused as "almost perfect"
    assert leak_reason("T_motor", motor, "E_z_um", target) is None
    assert leak_reason("T_bearing", np.asarray(recording["T_bearing"]), "E_z_um", target) is None


def test_a_sensor_over_a_short_warm_up_is_accepted():
    """200 calls of warm-up: the displacement barely leaves its noise and the motor temperature
    explains it within that noise, but the sensor's noise is its own, so it is no copy."""
    columns = simulate(2, seed=4)
    motor, target = np.asarray(columns["T_motor"])[:200], np.asarray(columns["E_z_um"])[:200]
    assert leak_reason("T_motor", motor, "E_z_um", target) is None


@pytest.mark.parametrize("seed", range(3))
def test_a_noisy_scaled_copy_of_the_target_is_refused(recording, seed):
    rng = np.random.default_rng(seed)
    target = recording["E_z_um"]
    copy = 21.0 + rng.uniform(0.01, 0.2) * (target + rng.normal(0.0, 0.5, len(target)))
    reason = leak_reason("T_probe", copy, "E_z_um", target)
    assert reason is not None and reason.startswith("is a copy of the target 'E_z_um'"), reason


def test_fit_and_diagnose_take_the_good_sensor_and_refuse_the_copy(recording, tmp_path):
    columns = dict(recording)
    noise = np.random.default_rng(9).normal(0, 0.5, len(columns["E_z_um"]))
    columns["T_probe"] = 20.0 + 0.05 * (columns["E_z_um"] + noise)
    (tmp_path / "good.csv").write_text(write_table(columns))
    thermoplc("fit", "--data", "good.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor",
              "--train-until", 43200, "-o", "m.json", cwd=tmp_path)
    refused = thermoplc("fit", "--data", "good.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_probe",
                        "--train-until", 43200, "-o", "p.json", cwd=tmp_path, check=2)
    assert "--temps column 'T_probe' is a copy of the target 'E_z_um'" in refused.stderr
    assert not (tmp_path / "p.json").exists()
    refused = thermoplc("diagnose", "--data", "good.csv", "--speed", "n_rpm", "--ambient", "T_env", "--temps",
                        "T_motor,T_probe", "--target", "E_z_um", "-o", "d.json", cwd=tmp_path, check=2)
    assert "'T_probe' is a copy of the target" in refused.stderr
