"""Vectorised float64 recurrences of paper 000 used while fitting (not the block's reference).

Per sensor the modified lumped-mass model (eq. 4) in discrete form is
    T[j] = A*T[j-1] + u[j],   u[j] = B*Te[j] + C*n[j] + D,
with A = tau/(tau+dt), B = 1-A, C = B*g_n (steady-state K per rpm), D = B*g_0 (K at standstill).
"""
from __future__ import annotations

import numpy as np


def lfilter(*args, **kwargs):  # scipy on first use: verify never fits, and importing it costs ~1 s
    from scipy.signal import lfilter as function
    return function(*args, **kwargs)


KALMAN_SETTLE = 1e-13  # relative change of the gain below which it is treated as constant


def discrete(tau: np.ndarray, g_n: np.ndarray, g_0: np.ndarray, dt: float):
    a = tau / (tau + dt)
    b = 1.0 - a
    return a, b, b * g_n, b * g_0


def open_loop(a, b, c, d, te, n, t_first) -> np.ndarray:
    """Simulated temperatures (population, rows) from speed and ambient alone (eq. 4), T[-1] = t_first."""
    a, b, c, d = (np.atleast_1d(v) for v in (a, b, c, d))
    out = np.empty((len(a), len(te)))
    for p in range(len(a)):
        u = b[p] * te + c[p] * n + d[p]
        out[p] = lfilter([1.0], [1.0, -a[p]], u, zi=[a[p] * t_first])[0]
    return out


def fused(a: float, u: np.ndarray, tm: np.ndarray, noise_n: np.ndarray, noise_r: np.ndarray, p_first: np.ndarray) -> np.ndarray:
    """Kalman-fused temperatures (population, rows) for one sensor (eq. 5-9), no fault gating.

    The gain sequence does not depend on the data; once it has settled the recursion is a fixed
    first-order filter and runs through lfilter.
    """
    pop = len(noise_n)
    rows = len(u)
    p = p_first.copy()
    gains = []
    for _ in range(rows):
        pp = a * a * p + noise_n
        k = pp / (pp + noise_r)
        p = pp - k * pp
        gains.append(k)
        if len(gains) > 1 and np.all(np.abs(gains[-1] - gains[-2]) <= KALMAN_SETTLE * np.abs(k)):
            break
    out = np.empty((pop, rows))
    tf = np.full(pop, tm[0])
    settled = len(gains)
    for j in range(settled):
        tp = a * tf + u[j]
        tf = tp + gains[j] * (tm[j] - tp)
        out[:, j] = tf
    if settled == rows:
        return out
    k = gains[-1]
    for q in range(pop):
        pole = (1.0 - k[q]) * a
        drive = (1.0 - k[q]) * u[settled:] + k[q] * tm[settled:]
        out[q, settled:] = lfilter([1.0], [1.0, -pole], drive, zi=[pole * out[q, settled - 1]])[0]
    return out
