"""Temperature-sensor selection.

- `fcm-grey` (paper 001): fuzzy clustering of the sensors - similarity |r| between their series,
  max-min transitive closure, the lambda-cut whose F statistic is largest - then, in each group,
  the sensor with the largest grey relational grade to the error (Deng, resolution 0.5).
- `grey-cluster` (paper 002): sensors grouped by their grey comprehensive correlation degree
  (mean of the grey absolute and relative degrees of incidence) at or above a threshold, then in
  each group the sensor most correlated (|Pearson r|) with the error.
Sensors in one group carry the same information; taking one per group avoids the collinearity
that makes regression coefficients unstable.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thermoplc.base.errors import UserError

RESOLUTION = 0.5


@dataclass(frozen=True)
class Selection:
    method: str
    groups: tuple[tuple[str, ...], ...]
    scores: dict  # sensor -> score used to pick inside a group
    chosen: tuple[str, ...]
    detail: str


def _minmax(x: np.ndarray) -> np.ndarray:
    span = x.max(axis=1, keepdims=True) - x.min(axis=1, keepdims=True)
    return (x - x.min(axis=1, keepdims=True)) / np.where(span > 0, span, 1.0)


def grey_relational_grades(series: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Deng's grey relational grade of each row of `series` to `reference` (min-max normalised)."""
    x = _minmax(series)
    y = _minmax(reference[None, :])[0]
    delta = np.abs(x - y)
    low, high = delta.min(), delta.max()
    coefficient = (low + RESOLUTION * high) / (delta + RESOLUTION * high)
    return coefficient.mean(axis=1)


def _groups_at(similarity: np.ndarray, level: float) -> list[list[int]]:
    n = len(similarity)
    label = list(range(n))
    for i in range(n):
        for j in range(i + 1, n):
            if similarity[i, j] >= level and label[j] != label[i]:
                old = label[j]
                label = [label[i] if v == old else v for v in label]
    groups: dict[int, list[int]] = {}
    for i, g in enumerate(label):
        groups.setdefault(g, []).append(i)
    return list(groups.values())


def _f_statistic(x: np.ndarray, groups: list[list[int]]) -> float:
    n, r = len(x), len(groups)
    if not 1 < r < n:
        return -np.inf
    centre = x.mean(axis=0)
    between = sum(len(g) * np.sum((x[g].mean(axis=0) - centre) ** 2) for g in groups) / (r - 1)
    within = sum(np.sum((x[g] - x[g].mean(axis=0)) ** 2) for g in groups) / (n - r)
    return float(between / within) if within > 0 else np.inf


def fuzzy_cluster(series: np.ndarray, max_groups: int) -> tuple[list[list[int]], float, float]:
    """Groups of rows by lambda-cut of the transitive closure of |r|, lambda chosen by F among the
    cuts with at most `max_groups` groups (F alone favours near-singleton cuts)."""
    similarity = np.abs(np.corrcoef(series))
    np.fill_diagonal(similarity, 1.0)
    for _ in range(len(series)):  # max-min closure converges within n compositions
        closure = np.max(np.minimum(similarity[:, :, None], similarity[None, :, :]), axis=1)
        if np.array_equal(closure, similarity):
            break
        similarity = closure
    x = _minmax(series)
    best = (-np.inf, 1.0, [[i] for i in range(len(series))])
    for level in sorted(set(np.round(similarity[np.triu_indices(len(series), 1)], 12)), reverse=True):
        groups = _groups_at(similarity, level)
        if len(groups) > max_groups:
            continue
        f = _f_statistic(x, groups)
        if f > best[0]:
            best = (f, level, groups)
    return best[2], best[1], best[0]


def grey_comprehensive_degree(a: np.ndarray, b: np.ndarray) -> float:
    """Mean of the grey absolute and relative degrees of incidence of two equal-length series."""
    def absolute(x, y):
        x0, y0 = x - x[0], y - y[0]
        sx = abs(np.sum(x0[1:-1]) + 0.5 * x0[-1])
        sy = abs(np.sum(y0[1:-1]) + 0.5 * y0[-1])
        sxy = abs(np.sum((x0 - y0)[1:-1]) + 0.5 * (x0 - y0)[-1])
        return (1 + sx + sy) / (1 + sx + sy + sxy)
    scale = lambda x: x / x[0] if x[0] != 0 else x - x[0] + 1.0
    return 0.5 * absolute(a, b) + 0.5 * absolute(scale(a), scale(b))


def select_sensors(columns: dict, target: np.ndarray, method: str, threshold: float = 0.9,
                   max_groups: int = 5, option: str = "--candidates") -> Selection:
    names = list(columns)
    if len(names) < 2:
        raise UserError("select-sensors needs at least two candidate temperature columns")
    series = np.array([columns[n] for n in names])
    flat = [n for n, s in zip(names, series) if np.ptp(s) == 0]
    if flat:
        raise UserError(f"{', '.join(flat)} does not change: not a sensor to choose from; leave it out of {option}")
    if method == "fcm-grey":
        groups, level, f = fuzzy_cluster(series, max_groups)
        scores = dict(zip(names, grey_relational_grades(series, target).tolist()))
        detail = f"fuzzy clustering: lambda = {level:.4f}, F = {f:.3g}; score: grey relational grade"
    elif method == "grey-cluster":
        n = len(names)
        degree = np.eye(n)
        for i in range(n):
            for j in range(i + 1, n):
                degree[i, j] = degree[j, i] = grey_comprehensive_degree(series[i], series[j])
        groups = _groups_at(degree, threshold)
        scores = {name: abs(float(np.corrcoef(columns[name], target)[0, 1])) for name in names}
        detail = f"grey clustering: comprehensive degree >= {threshold:g}; score: |Pearson r| with the error"
    else:
        raise UserError(f"unknown method {method!r}; use fcm-grey or grey-cluster")
    named = tuple(tuple(names[i] for i in g) for g in groups)
    chosen = tuple(max(g, key=lambda s: scores[s]) for g in named)
    return Selection(method, named, scores, chosen, detail)
