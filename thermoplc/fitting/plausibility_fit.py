"""Fitting the cross-sensor plausibility (models/plausibility.py) of a model's checked temperatures.

The relations on the training rows (least squares, float64, with an intercept: the absolute readings, so the
check needs no start and no state); the gate over every row of the runs given to fit, as the envelope's limits
are (fitting/envelope_fit.py says why): a gate bounds what the machine's sensors did, it is no parameter of the
model. FL_THERMAL's `t1_C` differed by up to 3.2 K on its held-out day against 2.1 K on its training day: the gate
from every row, with its margin of 2, leaves room for a day the recording did not have. The swing gate likewise:
each run's differences followed by their slow mean from the run's first row, as the block starts its means at
its first running call (rows with a missing reading left out). An ambient drives the machine through hours of
lag rather than following it: it is no slope of any relation, and its own relation (its training mean, no slopes)
has the swing test alone, as has a machine's only sensor beside an ambient.
"""
from __future__ import annotations

import numpy as np

from thermoplc.models.envelope import round_up
from thermoplc.models.model import Model
from thermoplc.models.kinds import checked_temperatures, driving_temperatures
from thermoplc.models.plausibility import GATE_FLOOR_K, MARGIN, Plausibility, deviations, swing_factors
from thermoplc.models.reference import model_inputs
from thermoplc.recordings.table import Table


def fit_plausibility(model: Model, tables: list[Table], n_train: list[int]) -> Plausibility | None:
    """The relations of `model`'s checked temperatures, None with fewer than two or without usable rows."""
    names = checked_temperatures(model)
    if len(names) < 2:
        return None
    readings = [np.column_stack([np.asarray(model_inputs(model, t)[name], np.float64) for name in names])
                for t in tables]
    runs = [r[np.isfinite(r).all(axis=1)] for r in readings]
    train = np.vstack([r[:n][np.isfinite(r[:n]).all(axis=1)] for r, n in zip(readings, n_train)])
    every = np.vstack(runs)
    if len(train) < len(names) + 1:
        return None
    keep, alpha = swing_factors(model.sample_period_s, "f64")
    drivers = driving_temperatures(model)
    followers = [i for i, name in enumerate(names) if name not in drivers]
    relations = []
    for i, sensor in enumerate(names):
        others = [j for j in followers if j != i] if i in followers else []
        design = np.column_stack([np.ones(len(train)), train[:, others]])
        coefficients = np.linalg.lstsq(design, train[:, i], rcond=None)[0]
        differences = [r[:, i] - np.column_stack([np.ones(len(r)), r[:, others]]) @ coefficients for r in runs]
        largest = float(np.max(np.abs(np.concatenate(differences)))) if others else None
        swung = max(float(np.max(deviations(d, keep, alpha, False, np.zeros(1), compiled_loop=True), initial=0.0))
                    for d in differences)
        relations.append((sensor, coefficients[0], [(names[j], b) for j, b in zip(others, coefficients[1:])],
                          max(round_up(MARGIN * largest), GATE_FLOOR_K) if others else None, largest,
                          max(round_up(MARGIN * swung), GATE_FLOOR_K), swung))
    return Plausibility.of(relations)
