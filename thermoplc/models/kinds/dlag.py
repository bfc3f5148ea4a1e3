"""Distributed-lag regression (paper 001's comparison model DL):
    E(t) = beta0 + sum_i sum_l beta_i_l * (T_i(t - l*s) - T_i[first call]),  l = 0..L
with s the lag step in samples. Before the start the lagged values equal the first sample.
The block keeps each sensor's last L*s+1 samples in a ring buffer.
"""
from __future__ import annotations

import numpy as np

from thermoplc.base import ridge
from thermoplc.base.binary32 import INT_RANGES
from thermoplc.base.errors import UserError
from thermoplc.models.kind import Increments, Kind, KindOption, Part, measured_counts, measured_rows
from thermoplc.models.kinds.mlr import least_squares, weight_by
from thermoplc.models.model import Coefficient, Model


def lagged(x: np.ndarray, step: int) -> np.ndarray:
    """x shifted back by `step` samples, holding the first sample before the start."""
    return x[np.maximum(np.arange(len(x)) - step, 0)]


MAX_BUFFER_SAMPLES = INT_RANGES["INT"][1]  # a PLC INT indexes the ring buffer


def fit_dlag(parts: list[Part], names: list[str], lags: int, lag_step_s: float, dt: float):
    """Least squares on each sensor's rise now and at `lags` lags `lag_step_s` apart (rounded to whole samples
    of `dt`), each run lagged from its own first row, the measured rows pooled; refuses a lag step under one
    sample or a ring buffer an INT cannot index."""
    step = int(round(lag_step_s / dt))
    if lags < 1 or step < 1:
        raise UserError(f"--lags must be at least 1 and --lag-step at least one sample ({dt:g} s)")
    if lags * step + 1 > MAX_BUFFER_SAMPLES:
        raise UserError(f"--lags {lags} x --lag-step {lag_step_s:g} s needs a ring buffer of {lags * step + 1} samples "
                        f"at {dt:g} s; the block indexes it with an INT, so at most {MAX_BUFFER_SAMPLES}: "
                        f"use fewer or shorter lags")
    sensors = parts[0].temps.shape[1]
    labels = [f"{names[i]}(t-{lag * step * dt:g}s)" for i in range(sensors) for lag in range(lags + 1)]
    design, target = measured_rows(parts, lambda part: _columns(part, lags, step))
    runs = measured_counts(parts)
    beta, log = least_squares(design, target, labels, runs)
    method = "least squares on current and lagged temperature rises"
    if len(runs) >= 2:  # the current rises alone (the lags' coefficients 0) unless the lags clearly do better
        now = [i * (lags + 1) for i in range(sensors)]  # the lag-0 columns
        current, current_log = least_squares(design[:, now], target, [labels[c] for c in now], runs)
        sums = ridge.RunSums.of(design, target, runs)
        if not ridge.beats(ridge.nested_run_errors(sums, range(design.shape[1])), ridge.nested_run_errors(sums, now)):
            beta = np.zeros(design.shape[1] + 1)
            beta[[0, *(c + 1 for c in now)]] = current
            log = current_log
            method += (" (the lagged rises did not beat the current ones by a standard error over the runs left out,"
                       " each run's weight chosen without it: the lags' coefficients are 0)")
    coefficients = {"beta0": Coefficient.of(beta[0])}
    k = 1
    for i in range(sensors):
        for lag in range(lags + 1):
            coefficients[f"beta_{i + 1}_{lag}"] = Coefficient.of(beta[k])
            k += 1
    settings = {"lags": lags, "lag_step_samples": step, "lag_step_s": step * dt}
    return coefficients, settings, {"method": f"{method}, ridge weight by {weight_by(log)}", **log}


def _columns(part: Part, lags: int, step: int) -> np.ndarray:
    """Each sensor's rise now and at each lag, sensor by sensor: the order of the slopes beta_i_lag."""
    sensors = part.temps.shape[1]
    return np.column_stack([lagged(part.temps[:, i], lag * step) - part.temps[0, i]
                            for i in range(sensors) for lag in range(lags + 1)])


def predict(model: Model, inputs: dict, precision: str) -> dict:
    """Reference in binary32 ('f32') or float64, adding lag by lag and sensor by sensor as the block does;
    returns {target name: error per row}."""
    f = np.float32 if precision == "f32" else np.float64
    lags, step = model.settings["lags"], model.settings["lag_step_samples"]
    temps = [np.asarray(inputs[s.name], f) for s in model.signals("temperature")]
    acc = np.full(len(temps[0]), model.coef("beta0", precision), f)
    for lag in range(lags + 1):  # lag by lag, sensor by sensor, as the block adds them
        for i, x in enumerate(temps, start=1):
            acc = acc + f(model.coef(f"beta_{i}_{lag}", precision)) * (lagged(x, lag * step) - x[0])
    return {model.target.name: acc}


def _fit(parts, request, names, dt, progress):
    return fit_dlag(parts, names, request.option("lags"), request.option("lag_step_s"), dt)


class StreamCore:
    """predict with the last lags*step samples of each sensor kept: a lagged value before the
    first call is the first call's sample, as `lagged` holds it."""

    def __init__(self, model: Model, precision: str, f):
        self.f, self.target = f, model.target.name
        self.temps = model.signals("temperature")
        self.lags, self.step = model.settings["lags"], model.settings["lag_step_samples"]
        self.beta0 = model.coef("beta0", precision)
        self.beta = {(i, lag): f(model.coef(f"beta_{i}_{lag}", precision))
                     for lag in range(self.lags + 1) for i in range(1, len(self.temps) + 1)}
        self.history = None  # per sensor: the last lags*step samples before this chunk
        self.first = None
        self.calls = 0

    def __call__(self, running: dict, fused_valid: dict) -> dict:
        f = self.f
        xs = [np.asarray(running[s.name], f) for s in self.temps]
        rows = len(xs[0])
        if self.first is None:
            self.first = [x[0] for x in xs]
            self.history = [x[:0] for x in xs]
        joined = [np.concatenate([h, x]) for h, x in zip(self.history, xs)]
        kept = len(self.history[0])
        acc = np.full(rows, self.beta0, f)
        for lag in range(self.lags + 1):
            at = kept + np.arange(rows) - lag * self.step
            before = self.calls + np.arange(rows) - lag * self.step < 0
            for i, (x, x0) in enumerate(zip(joined, self.first), start=1):
                lagged_values = np.where(before, x0, x[np.maximum(at, 0)])
                acc = acc + self.beta[(i, lag)] * (lagged_values - x0)
        span = self.lags * self.step
        self.history = [x[max(len(x) - span, 0):].copy() for x in joined]
        self.calls += rows
        return {self.target: acc}


SETTINGS_SCHEMA = {
    "type": "object",
    "required": ["lags", "lag_step_samples"],
    "properties": {"lags": {"type": "integer", "minimum": 1, "maximum": 1000},
                   "lag_step_samples": {"type": "integer", "minimum": 1, "maximum": 10000000},
                   "lag_step_s": {"type": "number", "exclusiveMinimum": 0}}}

INCREMENTS = Increments(lambda part, settings: _columns(part, settings["lags"], settings["lag_step_samples"]),
                        lambda settings, sensors: [f"beta_{i}_{lag}" for i in range(1, sensors + 1)
                                                   for lag in range(settings["lags"] + 1)])
OPTIONS = (
    KindOption("lags", "--lags", 3, "lagged terms per sensor (default: %(default)s)", number=(int, 1, 1000, "lags")),
    KindOption("lag_step_s", "--lag-step", 600.0, "time between lags (default: %(default)s)",
               number=(float, 1e-3, 1e7, "seconds"), metavar="SECONDS"),
)
def structure(model: Model) -> dict:
    """The ring buffer the block keeps: its step, length, last index and each lag's distance, in samples."""
    step, lags = model.settings["lag_step_samples"], model.settings["lags"]
    return {"one": 1, "len": lags * step + 1, "last": lags * step, **{f"lag_{lag}": lag * step for lag in range(lags + 1)}}


KIND = Kind("dlag", 4, "001", _fit, predict, options=OPTIONS, structure=structure, auto="closed-form",
            auto_sensors=8,
            settings_schema=SETTINGS_SCHEMA, stream_core=StreamCore, increments=INCREMENTS,
            shrunk=())
