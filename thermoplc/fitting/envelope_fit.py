"""Measuring the envelope (models/envelope.py) of a fitted model on every row of the runs it was fitted with.

Every row, the held-out ones too: a limit bounds what the machine does, it is no parameter of the model. A fit on
a 6 h warm-up (the golden twin: 26 um) does not span the 52 um the same recording reaches later, and a clamp
from its training rows alone costs the lumped golden 31 % of its held-out RMSE. Taken from the whole recording
the clamp never binds on it, so the held-out evidence stays the model's own; the rate limit is the measured
drift's and may act on a model that moves faster (benchmarks/limits.py counts the calls).
"""
from __future__ import annotations

import numpy as np

from thermoplc.models.envelope import Envelope
from thermoplc.models.model import Model
from thermoplc.models.reference import model_inputs, predict
from thermoplc.models.safety import stuck_checked
from thermoplc.recordings.table import Table


def measure_envelope(model: Model, tables: list[Table]) -> Envelope | None:
    """The largest |drift| and fastest change per call of the measured target and of every output of `model`
    (float64, its known start included), the largest |speed| and the longest run of calls a temperature input the
    block checks for a stuck sensor repeated its reading (as the REAL the block reads), over every row of `tables`;
    None without rows."""
    drift, step, speed, rows, same = [0.0, 0.0], [0.0, 0.0], 0.0, 0, 0
    checked = stuck_checked(model)
    for table in tables:
        rows += table.rows
        inputs = model_inputs(model, table)
        same = max([same, *(longest_repeat(inputs[name]) for name in checked)])
        outputs = [np.asarray(v, np.float64) for v in predict(model, inputs, "f64").values()
                   if np.asarray(v).dtype.kind == "f"]
        for k, series in enumerate(([np.asarray(table.columns[model.target.column], np.float64)], outputs)):
            for values in series:
                extent, fastest = _extremes(values)
                drift[k], step[k] = max(drift[k], extent), max(step[k], fastest)
        for signal in model.signals("speed"):
            values = np.abs(np.asarray(table.columns[signal.column], np.float64))
            if np.isfinite(values).any():
                speed = max(speed, float(np.nanmax(values)))
    if not rows:
        return None
    return Envelope(rows, (drift[0], drift[1]), (step[0], step[1]), speed if model.signals("speed") else None,
                    same if checked else None)


def longest_repeat(values: np.ndarray) -> int:
    """The most calls in a row whose reading equals the one before (NaN equals nothing)."""
    repeated = np.r_[False, values[1:] == values[:-1]]
    if not repeated.any():
        return 0
    edges = np.diff(np.r_[0, repeated.astype(np.int8), 0])
    return int((np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)).max())


def _extremes(values: np.ndarray) -> tuple[float, float]:
    """Largest |value| and largest |change| per call between finite values (a drift measured every few calls
    changes by its difference over the calls between)."""
    calls = np.flatnonzero(np.isfinite(values))
    if not len(calls):
        return 0.0, 0.0
    taken = values[calls]
    extent = float(np.max(np.abs(taken)))
    if len(calls) < 2:
        return extent, 0.0
    return extent, float(np.max(np.abs(np.diff(taken)) / np.diff(calls)))
