"""Distributed-lag regression (paper 001's comparison model DL):
    E(t) = beta0 + sum_i sum_l beta_i_l * (T_i(t - l*s) - T_i[first call]),  l = 0..L
with s the lag step in samples. Before the start the lagged values equal the first sample.
The block keeps each sensor's last L*s+1 samples in a ring buffer.
"""
from __future__ import annotations

import numpy as np

from thermoplc.base.binary32 import INT_RANGES
from thermoplc.base.errors import UserError
from thermoplc.models.mlr import least_squares
from thermoplc.models.modelfile import Coefficient, Model


def lagged(x: np.ndarray, step: int) -> np.ndarray:
    """x shifted back by `step` samples, holding the first sample before the start."""
    return x[np.maximum(np.arange(len(x)) - step, 0)]


MAX_BUFFER_SAMPLES = INT_RANGES["INT"][1]  # a PLC INT indexes the ring buffer


def fit_dlag(temps: np.ndarray, target: np.ndarray, names: list[str], lags: int, lag_step_s: float, dt: float):
    step = int(round(lag_step_s / dt))
    if lags < 1 or step < 1:
        raise UserError(f"--lags must be at least 1 and --lag-step at least one sample ({dt:g} s)")
    if lags * step + 1 > MAX_BUFFER_SAMPLES:
        raise UserError(f"--lags {lags} x --lag-step {lag_step_s:g} s needs a ring buffer of {lags * step + 1} samples "
                        f"at {dt:g} s; the block indexes it with an INT, so at most {MAX_BUFFER_SAMPLES}: "
                        f"use fewer or shorter lags")
    columns, labels = [], []
    for i in range(temps.shape[1]):
        for lag in range(lags + 1):
            columns.append(lagged(temps[:, i], lag * step) - temps[0, i])
            labels.append(f"{names[i]}(t-{lag * step * dt:g}s)")
    beta, log = least_squares(np.column_stack(columns), target, labels)
    coefficients = {"beta0": Coefficient.of(beta[0])}
    k = 1
    for i in range(temps.shape[1]):
        for lag in range(lags + 1):
            coefficients[f"beta_{i + 1}_{lag}"] = Coefficient.of(beta[k])
            k += 1
    settings = {"lags": lags, "lag_step_samples": step, "lag_step_s": step * dt}
    return coefficients, settings, {"method": "least squares on current and lagged temperature rises, ridge weight by "
                                              "forward validation", **log}


def predict(model: Model, inputs: dict, precision: str) -> dict:
    f = np.float32 if precision == "f32" else np.float64
    lags, step = model.settings["lags"], model.settings["lag_step_samples"]
    temps = [np.asarray(inputs[s.name], f) for s in model.signals("temperature")]
    acc = np.full(len(temps[0]), model.coef("beta0", precision), f)
    for lag in range(lags + 1):  # lag by lag, sensor by sensor, as the block adds them
        for i, x in enumerate(temps, start=1):
            acc = acc + f(model.coef(f"beta_{i}_{lag}", precision)) * (lagged(x, lag * step) - x[0])
    return {model.target.name: acc}
