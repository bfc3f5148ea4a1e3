"""Fitting the known start (models/start.py) of a fitted model on its training runs.

The drift the block outputs at its first call is the mean of the target's first measurement over the
training runs (a drift since the run's start: about 0). The decay is the one whose fading start offset
best explains the model's own residual on the training rows, `drift - model(first call)` times decay**call,
chosen from time constants of one call to the longest training run (least squares over every training row
of every run): a model whose start error lasts keeps the offset longer, one whose error is a first-call
artefact lets it go at once. Held-out rows never choose it.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from thermoplc.models.model import Model
from thermoplc.models.reference import model_inputs, predict
from thermoplc.models.start import Start
from thermoplc.recordings.table import Table

BELOW_ONE = 1.0 - 2.0 ** -24  # the largest binary32 below 1: the offset must fade
TIME_CONSTANTS_PER_DECADE = 12  # the decay's grid: time constants log-spaced from one call to the longest run


def fit_start(model: Model, tables: list[Table], n_train: list[int]) -> Start | None:
    """The known start of `model` (fitted without one) on the first `n_train` rows of each table; None when no
    run has a measured training row."""
    plain = replace(model, start=None)
    runs = []
    for table, n in zip(tables, n_train):
        if not n:  # a run held out whole
            continue
        measured = np.asarray(table.columns[model.target.column][:n], np.float64)
        value = predict(plain, {k: v[:n] for k, v in model_inputs(plain, table).items()}, "f64")[model.target.name]
        taken = np.isfinite(measured)
        if not taken.any():
            continue
        runs.append((np.flatnonzero(taken), measured[taken] - value[taken], measured[taken][0], value[0]))
    if not runs:
        return None
    drift = float(np.mean([first for _, _, first, _ in runs]))
    longest = max(len(calls) and calls[-1] + 1 for calls, _, _, _ in runs)
    taus = np.logspace(0, np.log10(max(longest, 2)), int(TIME_CONSTANTS_PER_DECADE * np.log10(max(longest, 10))) + 1)
    decays = np.concatenate([[0.0], np.exp(-1.0 / taus)])
    cost = np.zeros(len(decays))
    for calls, residual, _, first_value in runs:
        latched = drift - first_value
        if not np.isfinite(latched):
            continue
        faded = latched * decays[:, None] ** calls[None, :]
        cost += np.sum((residual[None, :] - faded) ** 2, axis=1)
    return Start.of(drift, min(float(decays[int(np.argmin(cost))]), BELOW_ONE))
