"""Plain regression (paper 000 eq. 10-11, 16): E = beta0 + sum_i beta_i * (T_i - T_i[first call])."""
from __future__ import annotations

import numpy as np

from thermoplc.base import ridge
from thermoplc.models.kind import Increments, Kind, Part, measured_counts, measured_rows
from thermoplc.models.model import Coefficient, Model


def least_squares(features: np.ndarray, target: np.ndarray, names: list[str], runs: list[int] | None = None
                  ) -> tuple[np.ndarray, dict]:
    """Intercept + slopes, ridge-shrunk by forward validation, or by leaving out each of `runs` (the rows'
    runs, base/ridge.py), and the fit's log."""
    fitted = ridge.fit_linear(features, target, names, runs=runs)
    return np.r_[fitted.intercept, fitted.slopes], fitted.log()


def fit_mlr(parts: list[Part], names: list[str]) -> tuple[dict[str, float], dict]:
    """The runs' training rows pooled; ΔT is taken from each run's first row, as the block does."""
    beta, log = least_squares(*measured_rows(parts, lambda part: part.rises), names, measured_counts(parts))
    return {"beta0": beta[0], **{f"beta_{i + 1}": b for i, b in enumerate(beta[1:])}}, log


def predict(model: Model, inputs: dict, precision: str) -> dict:
    """Reference: the block's arithmetic in binary32 ('f32') or the ideal float64 model ('f64').

    Order as in the block: ((beta0 + beta_1*(T_1 - T0_1)) + beta_2*(T_2 - T0_2)) + ...
    """
    dtype = np.float32 if precision == "f32" else np.float64
    temps = model.signals("temperature")
    betas = [model.coef("beta0", precision)] + [model.coef(f"beta_{i}", precision) for i in range(1, len(temps) + 1)]
    return {model.target.name: on_rises([inputs[s.name] for s in temps], betas, dtype)}


def on_rises(columns: list, coefficients: list, f) -> np.ndarray:
    """((c_0 + c_1*(x_1 - x_1[0])) + c_2*(x_2 - x_2[0])) + ... in `f`, each step rounded as the block rounds it:
    eq. 10 on each column's rise since the first call (mlr's output, bayes's ridge parent)."""
    out = np.full(len(columns[0]), f(coefficients[0]), f)
    for c, column in zip(coefficients[1:], columns):
        x = np.asarray(column, f)
        out = out + f(c) * (x - x[0])
    return out


def _fit(parts, request, names, dt, progress):
    values, log = fit_mlr(parts, names)
    coefficients = {k: Coefficient.of(v) for k, v in values.items()}
    return coefficients, {}, {"method": f"least squares (eq. 11), ridge weight by {weight_by(log)}", **log}


def weight_by(log: dict) -> str:
    """How the ridge weight was chosen, for the fit's method text: forward on one recording, else by runs."""
    return log.get("ridge_weight_by", "forward validation")


class StreamCore:
    """predict, with T0 (the first call's temperatures) kept between chunks."""

    def __init__(self, model: Model, precision: str, f):
        self.f = f
        self.temps = model.signals("temperature")
        self.beta0 = model.coef("beta0", precision)
        self.betas = [f(model.coef(f"beta_{i}", precision)) for i in range(1, len(self.temps) + 1)]
        self.first = None
        self.target = model.target.name

    def __call__(self, running: dict, fused_valid: dict) -> dict:
        f = self.f
        xs = [np.asarray(running[s.name], f) for s in self.temps]
        if self.first is None:
            self.first = [x[0] for x in xs]
        out = np.full(len(xs[0]), self.beta0, f)
        for beta, x, x0 in zip(self.betas, xs, self.first):
            out = out + beta * (x - x0)
        return {self.target: out}


INCREMENTS = Increments(lambda part, settings: part.rises,
                        lambda settings, sensors: [f"beta_{i}" for i in range(1, sensors + 1)])
KIND = Kind("mlr", 1, "000", _fit, predict, auto="closed-form", auto_sensors=8, stream_core=StreamCore, increments=INCREMENTS,
            shrunk=())
