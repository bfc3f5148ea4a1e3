"""Shared fixtures: a short synthetic recording and models fitted on it (small GA for speed)."""
from __future__ import annotations

import thermoplc  # noqa: F401  (first: it sets the BLAS thread count before numpy loads)

import pytest

from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.recordings.table import read_table, write_table
from thermoplc.machines.cascade import simulate

pytest_plugins = ["tests.file_progress"]  # a line per test file as it finishes

TEMPS = ("T_motor", "T_bearing")


@pytest.fixture(scope="session")
def twin_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("data") / "twin.csv"
    path.write_text(write_table(simulate(8, seed=11)))
    return path


@pytest.fixture(scope="session")
def twin_table(twin_csv):
    return read_table(twin_csv)


def fit_small(table, kind: str, **options):
    request = FitRequest(kind, "E_z_um", TEMPS, "n_rpm" if kind == "kalman" else None,
                         "T_env" if kind == "kalman" else None, train_until=4 * 3600.0,
                         settings={"population": 12, "generations": 4, **options})
    return fit([table], request)


@pytest.fixture(scope="session")
def mlr_model(twin_table):
    return fit_small(twin_table, "mlr")


@pytest.fixture(scope="session")
def kalman_model(twin_table):
    return fit_small(twin_table, "kalman")
