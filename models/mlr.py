"""Plain regression (paper 000 eq. 10-11, 16): E = beta0 + sum_i beta_i * (T_i - T_i[first call])."""
from __future__ import annotations

import numpy as np

from thermoplc.models import ridge
from thermoplc.models.modelfile import Model


def least_squares(features: np.ndarray, target: np.ndarray, names: list[str]) -> tuple[np.ndarray, dict]:
    """Intercept + slopes, ridge-shrunk by forward validation (models/ridge.py), and the fit's log."""
    fitted = ridge.fit_linear(features, target, names)
    return np.r_[fitted.intercept, fitted.slopes], fitted.log()


def fit_mlr(temps: np.ndarray, target: np.ndarray, names: list[str]) -> tuple[dict[str, float], dict]:
    """temps: (rows, sensors) training rows; ΔT is taken from the first training row, as the block does."""
    beta, log = least_squares(temps - temps[0], target, names)
    return {"beta0": beta[0], **{f"beta_{i + 1}": b for i, b in enumerate(beta[1:])}}, log


def predict(model: Model, inputs: dict, precision: str) -> dict:
    """Reference: the block's arithmetic in binary32 ('f32') or the ideal float64 model ('f64').

    Order as in the block: ((beta0 + beta_1*(T_1 - T0_1)) + beta_2*(T_2 - T0_2)) + ...
    """
    dtype = np.float32 if precision == "f32" else np.float64
    temps = model.signals("temperature")
    rows = len(inputs[temps[0].name])
    out = np.full(rows, model.coef("beta0", precision), dtype)
    for i, s in enumerate(temps, start=1):
        x = np.asarray(inputs[s.name], dtype)
        out = out + dtype(model.coef(f"beta_{i}", precision)) * (x - x[0])
    return {model.target.name: out}
