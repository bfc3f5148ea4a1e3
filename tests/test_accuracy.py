"""Issue 14: every kind is accurate, not only exact. On twin data each kind fits its training rows
well below the target's spread and within a stated factor of MLR; the regression and grey models
recover the coefficients of data made by their own equations."""
import numpy as np
import pytest

from thermoplc.models.kinds import grey
from thermoplc.models.kinds.dlag import fit_dlag, lagged
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.models.kinds.mlr import fit_mlr
from thermoplc.recordings.table import read_table, write_table
from thermoplc.machines.cascade import simulate
from thermoplc.models.kind import Part

# training RMSE at most this many times MLR's (measured on seeds 3 and 4: at most 0.4x for lumped,
# 1.0x kalman, 0.82x dlag, 1.82x gm0n, 0.72x gm1n, 2.16x bayes (8 intervals of 2 sensors), 1.12x bpnn)
FACTOR_OF_MLR = {"kalman": 1.5, "lumped": 1.0, "dlag": 1.2, "gm0n": 2.5, "gm1n": 1.2, "bayes": 3.0, "bpnn": 1.5}
SPREAD_SHARE = {"bayes": 0.8, "gm0n": 0.7}  # training RMSE below this share of the target's std (else 0.5)


@pytest.fixture(scope="module")
def twin(tmp_path_factory):
    path = tmp_path_factory.mktemp("accuracy") / "twin.csv"
    path.write_text(write_table(simulate(24, seed=4)))
    return read_table(path)


def _fit(table, kind: str):
    extra = ("n_rpm", "T_env") if kind in ("kalman", "lumped") else (None, None)
    return fit([table], FitRequest(kind, "E_z_um", ("T_motor", "T_bearing"), *extra, train_rows=table.rows // 2,
                                   settings={"seed": 0}))


@pytest.mark.parametrize("kind", sorted(FACTOR_OF_MLR))
def test_each_kind_fits_its_training_rows(twin, kind):
    spread = float(np.std(twin.columns["E_z_um"][:twin.rows // 2]))
    mlr = _fit(twin, "mlr").metrics["train"]["rmse_um"]
    rmse = _fit(twin, kind).metrics["train"]["rmse_um"]
    assert rmse < SPREAD_SHARE.get(kind, 0.5) * spread, (rmse, spread)
    assert rmse <= FACTOR_OF_MLR[kind] * mlr, (rmse, mlr)


def _temperatures(rows: int, sensors: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return 20.0 + np.cumsum(rng.normal(0.0, 0.05, (rows, sensors)), axis=0)


def test_mlr_recovers_its_equation():
    temps = _temperatures(3000, 3, 1)
    beta = np.array([1.5, 2.0, -0.7, 0.3])
    target = beta[0] + (temps - temps[0]) @ beta[1:]
    fitted, log = fit_mlr([Part(temps, target, np.empty((len(target), 0)), None, None)], ["a", "b", "c"])
    assert log["ridge_weight"] == 0.0  # noise-free: forward validation keeps least squares
    assert np.allclose([fitted["beta0"], fitted["beta_1"], fitted["beta_2"], fitted["beta_3"]], beta, atol=1e-9)


def test_dlag_recovers_its_equation():
    temps = _temperatures(4000, 2, 2)
    step, lags = 30, 2
    beta0, beta = 0.8, {(0, 0): 1.2, (0, 1): -0.4, (0, 2): 0.1, (1, 0): 0.5, (1, 1): 0.2, (1, 2): -0.3}
    target = beta0 + sum(b * (lagged(temps[:, i], lag * step) - temps[0, i]) for (i, lag), b in beta.items())
    coefficients, _, _ = fit_dlag([Part(temps, target, np.empty((len(target), 0)), None, None)], ["a", "b"], lags, lag_step_s=step * 10.0, dt=10.0)
    assert coefficients["beta0"].f64 == pytest.approx(beta0, abs=1e-8)
    for (i, lag), b in beta.items():
        assert coefficients[f"beta_{i + 1}_{lag}"].f64 == pytest.approx(b, abs=1e-8)


def test_gm0n_recovers_its_equation():
    temps = _temperatures(2000, 2, 3)
    a, b = 4.0, np.array([0.02, -0.015])
    accumulated = a + np.cumsum(temps, axis=0) @ b
    target = np.diff(accumulated, prepend=accumulated[0] - 3.0)
    coefficients, _, _ = grey.fit_gm0n([Part(temps, target, np.empty((len(target), 0)), None, None)], ["a", "b"])
    assert coefficients["b_1"].f64 == pytest.approx(b[0], rel=1e-6)
    assert coefficients["b_2"].f64 == pytest.approx(b[1], rel=1e-6)


def test_piecewise_recovers_each_nodes_equation():
    from thermoplc.models.kinds.piecewise import fit_piecewise
    truth = {10.0: (0.5, [1.0, -0.4]), 20.0: (1.5, [2.0, 0.3]), 30.0: (-1.0, [0.7, 0.9])}
    batches = []
    for k, (ambient, (beta0, beta)) in enumerate(sorted(truth.items())):
        for run in range(2):
            temps = _temperatures(1500, 2, 10 + 2 * k + run) + ambient - 20.0
            target = beta0 + (temps - temps[0]) @ np.array(beta)
            batches.append((temps, np.full(len(temps), ambient + 0.3 * run), target))
    coefficients, settings, _ = fit_piecewise(batches, ["a", "b"])
    assert [n["node_C"] for n in settings["nodes"]] == sorted(truth)
    for m, (beta0, beta) in enumerate((truth[a] for a in sorted(truth)), start=1):
        assert coefficients[f"beta0_{m}"].f64 == pytest.approx(beta0, abs=1e-8)
        assert [coefficients[f"beta_{i}_{m}"].f64 for i in (1, 2)] == pytest.approx(beta, abs=1e-8)


def test_piecewise_fits_ambient_batches_of_the_twin(tmp_path):
    tables = []
    for k, ambient in enumerate((14.0, 19.0, 26.0, 31.0)):
        path = tmp_path / f"batch{k}.csv"
        path.write_text(write_table(simulate(8, seed=20 + k, ambient_start=ambient)))
        tables.append(read_table(path))
    model = fit(tables, FitRequest("piecewise", "E_z_um", ("T_motor", "T_bearing"), ambient="T_env",
                                   train_until=6 * 3600.0))
    spread = float(np.std(np.concatenate([t.columns["E_z_um"][:model.metrics["train"]["rows"] // 4] for t in tables])))
    assert model.metrics["train"]["rmse_um"] < 0.5 * spread
