"""Grey models GM(0,N) and GM(1,N) on first-order accumulated (1-AGO) sequences (paper 003).

With S_i(k) = x_i(1) + ... + x_i(k) the running sums of the temperatures:
- GM(0,N): X1(k) = a + sum_i b_i*S_i(k); the error estimate is X1(k) - X1(k-1), and x1(1) (the
  error at the first sample of the fit) at the first call, where X1(0) is not defined.
- GM(1,N): the grey difference equation the parameters are estimated from,
  x1(k) + a*z1(k) = sum_i b_i*S_i(k) with the background value z1(k) = (X1(k) + X1(k-1))/2,
  run forward: X1(k) = Keep*X1(k-1) + In*sum_i b_i*S_i(k), Keep = (1 - a/2)/(1 + a/2),
  In = 1/(1 + a/2), and the error estimate x1(k) = X1(k) - X1(k-1); x1(1) at the first call.
  (The whitened time response, which treats sum_i b_i*S_i as constant, does not fit even the
  training data when the sums grow and a is small; this recursion needs no exp either.)
GM(1,1), the paper's baseline, is GM(1,N) without temperatures (a time trend only).
"""
from __future__ import annotations

import numpy as np

from thermoplc.errors import UserError
from thermoplc.models import kernels
from thermoplc.models.modelfile import Coefficient, Model

def accumulate(x: np.ndarray) -> np.ndarray:
    return np.cumsum(x, axis=0)


def fit_gm0n(temps: np.ndarray, target: np.ndarray, names: list[str]):
    sums, target_sums = accumulate(temps), accumulate(target)
    design = np.column_stack([np.ones(len(target) - 1), sums[1:]])
    beta = np.linalg.lstsq(design, target_sums[1:], rcond=None)[0]
    coefficients = {"a": Coefficient.of(beta[0]), "X1": Coefficient.of(target[0]),
                    **{f"b_{i}": Coefficient.of(b) for i, b in enumerate(beta[1:], start=1)}}
    return coefficients, {}, {"method": "least squares on 1-AGO sequences (paper 003, GM(0,N))"}


def _gm1n_parameters(sums: np.ndarray, target: np.ndarray) -> np.ndarray:
    """[a, b_1..b_N] by least squares: x1(k) = -a*z1(k) + sum_i b_i*S_i(k), k = 2..n."""
    target_sums = accumulate(target)
    background = 0.5 * (target_sums[1:] + target_sums[:-1])
    return np.linalg.lstsq(np.column_stack([-background, sums[1:]]), target[1:], rcond=None)[0]


def fit_gm1n(temps: np.ndarray, target: np.ndarray, names: list[str]):
    params = _gm1n_parameters(accumulate(temps), target)
    a, b = float(params[0]), params[1:]
    if not 0 < a < 2:
        raise UserError(f"GM(1,N) fit gives development coefficient a = {a:.4g}; the grey difference equation only "
                        f"settles for 0 < a < 2 (use --model gm0n, or other sensors)")
    coefficients = {"X1": Coefficient.of(target[0]), "Keep": Coefficient.of((1 - a / 2) / (1 + a / 2)),
                    "In": Coefficient.of(1 / (1 + a / 2)),
                    **{f"b_{i}": Coefficient.of(bi) for i, bi in enumerate(b, start=1)}}
    settings = {"a": a, "b": [float(x) for x in b]}
    return coefficients, settings, {"method": "least squares on 1-AGO sequences, run as the grey difference "
                                              "equation (paper 003, GM(1,N))"}


def gm11_predict(target_train: np.ndarray, rows: int) -> np.ndarray:
    """GM(1,1) baseline (float64): fitted on the training target, extrapolated over `rows` samples."""
    a, b = _gm1n_parameters(np.ones((len(target_train), 1)), target_train)
    accumulated = (target_train[0] - b / a) * np.exp(-a * np.arange(rows)) + b / a
    return np.diff(accumulated, prepend=0.0)


def predict_gm0n(model: Model, inputs: dict, precision: str) -> dict:
    f = np.float32 if precision == "f32" else np.float64
    temps = [np.asarray(inputs[s.name], f) for s in model.signals("temperature")]
    a, x1 = f(model.coef("a", precision)), f(model.coef("X1", precision))
    b = [f(model.coef(f"b_{i}", precision)) for i in range(1, len(temps) + 1)]
    if kernels.enabled():  # the same loop, compiled (models/kernels.py)
        return {model.target.name: kernels.gm0n(temps, a, x1, b, f)}
    sums = [f(0.0)] * len(temps)
    previous = f(0.0)
    out = np.empty(len(temps[0]), f)
    for k in range(len(out)):
        for i, x in enumerate(temps):
            sums[i] = sums[i] + x[k]
        level = a
        for i in range(len(temps)):
            level = level + b[i] * sums[i]
        if k == 0:
            previous = level - x1
        out[k] = level - previous
        previous = level
    return {model.target.name: out}


def predict_gm1n(model: Model, inputs: dict, precision: str) -> dict:
    f = np.float32 if precision == "f32" else np.float64
    temps = [np.asarray(inputs[s.name], f) for s in model.signals("temperature")]
    c = lambda name: f(model.coef(name, precision))
    b = [c(f"b_{i}") for i in range(1, len(temps) + 1)]
    x1, keep, gain = c("X1"), c("Keep"), c("In")
    if kernels.enabled():  # the same loop, compiled (models/kernels.py)
        return {model.target.name: kernels.gm1n(temps, x1, keep, gain, b, f)}
    sums = [f(0.0)] * len(temps)
    previous = f(0.0)
    out = np.empty(len(temps[0]), f)
    for k in range(len(out)):
        for i, x in enumerate(temps):
            sums[i] = sums[i] + x[k]
        forced = b[0] * sums[0]
        for i in range(1, len(temps)):
            forced = forced + b[i] * sums[i]
        level = x1 if k == 0 else keep * previous + gain * forced
        out[k] = level - previous
        previous = level
    return {model.target.name: out}
