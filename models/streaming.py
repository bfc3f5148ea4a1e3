"""The block's reference (models/safety.py::guarded_predict around the model) computed chunk by
chunk, with the block's memory carried from one chunk to the next, so a recording of any length
is verified in bounded memory (issue 17).

Same operations, same order, same results as block_outputs on the whole recording (the tests
compare them bit for bit, chunk boundaries anywhere). Per kind the model's state carries over:
the compiled loops' state arrays (kalman, grey, lumped), the first call's values and, for dlag,
the last lags*step samples; mlr, piecewise, bpnn and bayes depend on the current and the first
call only. A bayes model with the elapsed-time parent is not streamed (`streamable`); the caller
then computes the reference in one piece.
"""
from __future__ import annotations

import numpy as np

from thermoplc.models import kernels
from thermoplc.models.kalman import kernel_coefficients
from thermoplc.models.modelfile import Model
from thermoplc.models.reference import _core
from thermoplc.models.safety import ENO, Limits, _real_outputs_of, axis_outputs, fault_flags, guards

NOT_YET = np.iinfo(np.int64).max  # the ready row before any call had every input in range
# kinds whose output at a call depends on that call and the first call only: the model's own
# predict runs on [first call, chunk...] and the first value is dropped
FIRST_CALL_KINDS = ("mlr", "piecewise", "bpnn", "bayes")
STREAMED_KINDS = ("kalman", "gm0n", "gm1n", "dlag", "lumped", *FIRST_CALL_KINDS)


def streamable(model: Model) -> bool:
    if model.kind == "bayes" and model.settings.get("time_parent"):
        return False  # elapsed time since the first call is an input: not a first-call-only model
    return model.kind in STREAMED_KINDS and kernels.enabled()


class _KalmanCore:
    def __init__(self, model: Model, precision: str, f):
        self.f = f
        self.temps = model.signals("temperature")
        self.ambient = model.signals("ambient")[0].name
        self.speed = model.signals("speed")[0].name
        self.args = kernel_coefficients(model, precision)
        self.state = kernels.KalmanState(len(self.temps), f)
        self.target = model.target.name

    def __call__(self, running: dict, fused_valid: dict) -> dict:
        rows = len(running[self.ambient])
        in_range = [np.asarray(fused_valid[s.name], bool) if s.name in fused_valid else np.ones(rows, bool)
                    for s in self.temps]
        error, faults = kernels.kalman(running[self.ambient], running[self.speed],
                                       [np.asarray(running[s.name], self.f) for s in self.temps], in_range,
                                       *self.args, self.f, self.state)
        out = {self.target: error}
        out.update({f"Fault_{i + 1}": faults[i] for i in range(len(self.temps))})
        return out


class _FirstCallCore:
    """The kind's own predict (models/reference.py::predict), on the first call and this chunk."""

    def __init__(self, model: Model, precision: str, f):
        from thermoplc.models.reference import predict
        self.predict = lambda inputs: predict(model, inputs, precision)
        self.first = None

    def __call__(self, running: dict, fused_valid: dict) -> dict:
        if self.first is None:
            self.first = {name: np.asarray(values)[:1].copy() for name, values in running.items()}
            return self.predict(running)
        joined = {name: np.concatenate([self.first[name], np.asarray(values, self.first[name].dtype)])
                  for name, values in running.items()}
        return {name: values[1:] for name, values in self.predict(joined).items()}


class _GreyCore:
    """models/grey.py::predict_gm0n / predict_gm1n with the sums and the last level kept."""

    def __init__(self, model: Model, precision: str, f):
        self.f, self.kind, self.target = f, model.kind, model.target.name
        self.temps = model.signals("temperature")
        c = lambda name: f(model.coef(name, precision))
        self.b = [c(f"b_{i}") for i in range(1, len(self.temps) + 1)]
        self.scalars = (c("a"), c("X1")) if model.kind == "gm0n" else (c("X1"), c("Keep"), c("In"))
        self.state = kernels.GreyState(len(self.temps), f)

    def __call__(self, running: dict, fused_valid: dict) -> dict:
        temps = [np.asarray(running[s.name], self.f) for s in self.temps]
        if self.kind == "gm0n":
            out = kernels.gm0n(temps, *self.scalars, self.b, self.f, self.state)
        else:
            out = kernels.gm1n(temps, *self.scalars, self.b, self.f, self.state)
        return {self.target: out}


class _DlagCore:
    """models/dlag.py::predict with the last lags*step samples of each sensor kept: a lagged value
    before the first call is the first call's sample, as `lagged` holds it."""

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
                lagged = np.where(before, x0, x[np.maximum(at, 0)])
                acc = acc + self.beta[(i, lag)] * (lagged - x0)
        span = self.lags * self.step
        self.history = [x[max(len(x) - span, 0):].copy() for x in joined]
        self.calls += rows
        return {self.target: acc}


class _LumpedCore:
    """models/lumped_model.py::predict with the simulation's state kept (kernels.LumpedState)."""

    def __init__(self, model: Model, precision: str, f):
        from thermoplc.models.lumped_model import kernel_arguments
        self.f, self.target, self.model, self.precision = f, model.target.name, model, precision
        self.arguments = kernel_arguments
        self.state = None

    def __call__(self, running: dict, fused_valid: dict) -> dict:
        out, self.state = self.arguments(self.model, running, self.precision, self.state)
        return {self.target: out}


class _MlrCore:
    """models/mlr.py::predict, with T0 (the first call's temperatures) kept between chunks."""

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


class StreamingReference:
    """block_outputs(model, inputs, precision, limits), one chunk of calls at a time."""

    def __init__(self, model: Model, limits: Limits, precision: str):
        if not streamable(model):
            raise ValueError(f"{model.kind} models are not streamed")
        self.model = model
        self.f = f = np.float32 if precision == "f32" else np.float64
        self.limits = limits
        self.constants = limits.constants()
        self.plan = guards(model)
        core = {"kalman": _KalmanCore, "gm0n": _GreyCore, "gm1n": _GreyCore, "mlr": _MlrCore, "dlag": _DlagCore,
                "lumped": _LumpedCore}
        self.core = core.get(model.kind, _FirstCallCore)(model, precision, f)
        self.names = _real_outputs_of(model, _core, precision)  # what the limiter acts on, in order
        self.axes = axis_outputs(model, self.names)
        self.holds = {g.name: kernels.HoldState(f) for g in self.plan if g.kind != "fused"}
        self.y = {name: np.zeros(1, f) for name in self.names}
        self.ready = NOT_YET
        self.calls = 0

    def step(self, inputs: dict) -> dict:
        """Every block output for the next len(inputs) calls, as block_outputs would give them."""
        with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
            return self._step(inputs)

    def _step(self, inputs: dict) -> dict:
        f, constants, offset = self.f, self.constants, self.calls
        rows = len(next(iter(inputs.values())))
        raw = {g.name: np.asarray(inputs[g.name], f) for g in self.plan}
        valid = {g.name: (raw[g.name] >= f(constants[g.low])) & (raw[g.name] <= f(constants[g.high]))
                 for g in self.plan}
        if self.ready == NOT_YET:
            all_valid = np.logical_and.reduce([valid[g.name] for g in self.plan])
            if all_valid.any():
                self.ready = offset + int(np.argmax(all_valid))
        local = int(min(max(self.ready - offset, 0), rows))
        core_inputs, faults = {}, {}
        for g in self.plan:
            if g.kind == "fused":
                core_inputs[g.name] = raw[g.name]
            else:
                core_inputs[g.name], faults[g.name] = kernels.hold(
                    raw[g.name], valid[g.name], g.kind == "range", self.ready, self.limits.settle_calls,
                    self.limits.max_jump_K, f, self.holds[g.name], offset)
        core = None
        if local < rows:
            running = {name: values[local:] for name, values in core_inputs.items()}
            fused_valid = {g.name: valid[g.name][local:] for g in self.plan if g.kind == "fused"}
            core = self.core(running, fused_valid)
        out = {}
        limited, clamped, invalid = (np.zeros(rows, bool) for _ in range(3))
        for name in self.names:
            series = np.zeros(rows, f)
            if core is not None:
                kernels.limit(core[name], local, self.y[name], series, limited, clamped, invalid, constants, f)
            out[name] = series
        for k, name in enumerate(self.axes, start=1):
            k0 = np.zeros(rows, f)
            k0[local:] = out[name][local:] * f(constants["c_K0_mm"])
            out[f"K0_{k}"] = k0
        out.update(fault_flags(self.plan, valid, faults, core, local))
        out["Ready"] = np.arange(offset, offset + rows) >= self.ready
        out["Limited"] = limited
        out["Clamped"] = clamped
        out["Invalid"] = invalid
        out[ENO] = np.ones(rows, bool)  # enabled on every call: the whole-recording path replays Enable and Reset
        self.calls += rows
        return out
