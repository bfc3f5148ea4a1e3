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

from thermoplc.base import compiled

from thermoplc.models import kernels
from thermoplc.models.kinds import kind_of
from thermoplc.models.model import Model
from thermoplc.models.plausibility import CheckState
from thermoplc.models.reference import guarded_core, with_start
from thermoplc.models.safety import (CLAMPED, ENABLED, INVALID, LIMITED, READY, Limits, axis_outputs, checked_values,
                                     fault_flags, guards, held_while_faulty, in_range, k0_key, real_outputs_of,
                                     sensors_disagree, stuck_readings)

NOT_YET = np.iinfo(np.int64).max  # the ready row before any call had every input in range


def streamable(model: Model) -> bool:
    """The chunked route computes its reference with the compiled loops alone (models/kernels.py)."""
    return kind_of(model.kind).streamable(model) and compiled.could_compile()


class _FirstCallCore:
    """The kind's own predict (models/reference.py::predict), on the first call and this chunk: for a
    kind whose output at a call depends on that call and the first call only."""

    def __init__(self, model: Model, precision: str, f):
        self.predict = lambda inputs: kind_of(model.kind).predict(model, inputs, precision)
        self.first = None

    def __call__(self, running: dict, fused_valid: dict) -> dict:
        if self.first is None:
            self.first = {name: np.asarray(values)[:1].copy() for name, values in running.items()}
            return self.predict(running)
        joined = {name: np.concatenate([self.first[name], np.asarray(values, self.first[name].dtype)])
                  for name, values in running.items()}
        return {name: values[1:] for name, values in self.predict(joined).items()}


class StreamingReference:
    """block_outputs(model, inputs, precision, limits), one chunk of calls at a time."""

    def __init__(self, model: Model, limits: Limits, precision: str):
        if not streamable(model):
            raise ValueError(f"{model.kind} models are not streamed")
        self.model = model
        self.precision = precision
        self.f = f = np.float32 if precision == "f32" else np.float64
        self.limits = limits
        self.constants = limits.values()
        self.plan = guards(model)
        self.core = (kind_of(model.kind).stream_core or _FirstCallCore)(model, precision, f)
        self.names = real_outputs_of(model, guarded_core, precision)  # what the limiter acts on, in order
        self.axes = axis_outputs(model, self.names)
        self.holds = {g.name: kernels.HoldState(f) for g in self.plan if g.kind != "fused"}
        self.repeats = {g.name: kernels.RepeatState(f) for g in self.plan if g.kind != "range"}
        self.y = {name: np.zeros(1, f) for name in self.names}
        self.start_state = np.zeros(2, f)  # the known start's offset and latch (models/start.py)
        self.hold_states = {name: np.zeros(3, f) for name in self.names}  # models/fault_hold.py, per output
        self.disagree_state = (CheckState(f, len(model.plausibility.relations)) if model.plausibility is not None
                               else None)  # models/plausibility.py
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
        valid = in_range(self.plan, raw, constants, f)
        repeated = {name: stuck_readings(raw[name], valid[name], self.limits, f, state)
                    for name, state in self.repeats.items()}
        stuck = {name: flags for name, (flags, _) in repeated.items()}
        for g in self.plan:
            if g.kind == "fused":  # a stuck reading is no reading for the model's own filter
                valid[g.name] = valid[g.name] & ~stuck[g.name]
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
                    raw[g.name], valid[g.name], stuck.get(g.name, np.zeros(rows, bool)), g.kind == "range",
                    self.ready, self.limits.settle_calls, self.limits.max_jump_K, f, self.holds[g.name], offset)
        core = None
        if local < rows:
            running = {name: values[local:] for name, values in core_inputs.items()}
            fused_valid = {g.name: valid[g.name][local:] for g in self.plan if g.kind == "fused"}
            core = with_start(self.model, self.core(running, fused_valid), self.precision, self.start_state)
        flags = fault_flags(self.plan, valid, faults, core, local)
        status = sensors_disagree(self.model, checked_values(self.plan, core_inputs, repeated), local, self.limits,
                                  self.precision, self.disagree_state)
        core = held_while_faulty(core, self.names, {**flags, **status}, local, self.limits, self.precision,
                                 self.hold_states)
        out = {}
        limited, clamped, invalid = (np.zeros(rows, bool) for _ in range(3))
        for name in self.names:
            series = np.zeros(rows, f)
            if core is not None:
                kernels.limit(core[name], local, self.y[name], series, limited, clamped, invalid, constants, f)
            out[name] = series
        for k, name in enumerate(self.axes, start=1):
            k0 = np.zeros(rows, f)
            k0[local:] = out[name][local:] * f(constants["k0_mm"])
            out[k0_key(k)] = k0
        out.update(flags)
        out.update(status)
        out[READY] = np.arange(offset, offset + rows) >= self.ready
        out[LIMITED] = limited
        out[CLAMPED] = clamped
        out[INVALID] = invalid
        out[ENABLED] = np.ones(rows, bool)  # enabled on every call: the whole-recording path replays Enable and Reset
        self.calls += rows
        return out
