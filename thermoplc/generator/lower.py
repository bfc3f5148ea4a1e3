"""Models -> block IR. The expression trees are the operation order the references follow;
each kind's lowering lives in its own module, this one picks it and adds the safety logic."""
from __future__ import annotations

import functools
import importlib
import pkgutil
from dataclasses import replace

from thermoplc.generator.commissioning import with_commissioning
from thermoplc.generator.ir import Block, GenerationError, Identity
from thermoplc.generator.probing import Fusion
from thermoplc.generator.start import KnownStart
from thermoplc.generator.ranges import RangeProof, prove_ranges
from thermoplc.generator.safety import with_safety
from thermoplc.models.model import Model
from thermoplc.contract.constants import (SWING_ALPHA, SWING_KEEP, plausibility_constants, plausibility_names, probe_constants,
                                         start_constants)
from thermoplc.generator.plausibility import Check, Relation as PlausibleRelation
from thermoplc.models.plausibility import GATE_FLOOR_K, MARGIN, SWING_S
from thermoplc.contract.outputs import ENABLE_INPUT, PROBE_VALUE_INPUT, READY_OUTPUT, fault_outputs
from thermoplc.models.safety import Limits, axis_outputs, guards



@functools.cache
def lowerings() -> dict:
    """Model kind -> lowering, from every `generator/lower_*.py` that declares LOWERINGS: a new kind's
    lowering is a new module, registered beside its code."""
    import thermoplc.generator as package
    found = {}
    for module in pkgutil.iter_modules(package.__path__):
        if module.name.startswith("lower_"):
            found.update(getattr(importlib.import_module(f"{package.__name__}.{module.name}"), "LOWERINGS", {}))
    return found


def lower_model(model: Model) -> Block:
    """What the model computes, without the safety logic (its cost is reported apart)."""
    lowering = lowerings().get(model.kind)
    if lowering is None:
        raise GenerationError(f"no lowering for model kind {model.kind!r}")
    return lowering(model)


def lower(model: Model, limits: Limits | None = None, identity: Identity | None = None, retain: bool = False) -> Block:
    """The block for `model`, inside the input guards and output limits every block carries (`limits` None:
    the model's own, Limits.for_model), with Enable/ENO and Reset; `identity` defaults to a new block's
    (VERSION 0.1, no date): the command line counts the version on from the block it replaces
    (generator/identity.py)."""
    limits = Limits.for_model(model) if limits is None else limits
    core = lower_model(model)
    _refuse_unread_inputs(model, core)
    axes = axis_outputs(model, [v.name for v in core.outputs if v.type == "REAL"])
    start = KnownStart(model.target.name, start_constants(model)) if model.start is not None else None
    block = with_commissioning(with_safety(core, guards(model), axes, limits, fault_outputs(model), _fusion(model),
                                           start, _check(model)))
    return replace(block, identity=identity or Identity(), retain=retain)


def _fusion(model: Model) -> Fusion | None:
    """What the probe fusion adds to the block of a model fitted with probings; None for a static model."""
    if model.probe is None:
        return None
    return Fusion(model.target.name, probe_constants(model), model.probe.has_rate, model.probe.decay is not None,
                  model.probe.min_calls is not None)


def _check(model: Model) -> Check | None:
    """The cross-sensor check of a model fitted with one (models/plausibility.py), on the inputs' held values."""
    if model.plausibility is None:
        return None
    index = {g.name: g.index for g in guards(model)}
    held = {g.name: f"{'LastIn' if g.kind == 'fused' else 'Good'}_{g.index}" for g in guards(model)}
    names = plausibility_names(model)
    swings = model.plausibility.swings
    relations, comments = [], {}
    for r in model.plausibility.relations:
        intercept, slopes, gate, quiet, swing, swing_quiet = names[r.sensor]
        level = r.gate_K is not None
        relations.append(PlausibleRelation(held[r.sensor], intercept, tuple((held[name], slopes[name])
                                                                            for name, _ in r.slopes),
                                           gate if level else None, quiet if level else None,
                                           (swing, swing_quiet, f"PlausMean_{index[r.sensor]}")
                                           if swings else None, r.sensor))
        comments.update(_check_comments(model, r, names[r.sensor]))
    return Check(tuple(relations), plausibility_constants(model), comments,
                 (SWING_KEEP, SWING_ALPHA) if swings else None)


def _check_comments(model: Model, r, names: tuple) -> dict:
    """What each constant of one relation of the cross-sensor check is, and how it was chosen."""
    intercept, slopes, gate, quiet, swing, swing_quiet = names
    others = ", ".join(name for name, _ in r.slopes)
    comments = {intercept: (f"{r.sensor} as the others say it should read: this, K" if r.slopes else
                            f"{r.sensor}'s mean reading recorded, K: the others do not tell it, only its swing is checked"),
                **{slopes[name]: f"... plus this times {name}, K per K" for name, _ in r.slopes}}
    if r.gate_K is not None:
        recorded = f"{MARGIN:g} x the largest difference recorded, {r.largest_K:.3g} K, rounded up"
        comments[gate] = (f"{r.sensor} further than this from what {others} {'says' if len(r.slopes) == 1 else 'say'} "
                          f"sets SensorsDisagree, K: "
                          + (recorded if r.gate_K[0] > GATE_FLOOR_K else f"at least {GATE_FLOOR_K:g} K ({recorded} "
                                                                         f"is less)"))
        comments[quiet] = (f"{r.sensor} inside this (half the gate) counts as agreeing again, K; SensorsDisagree "
                           f"clears after c_SettleCalls such calls")
    if r.swing_K is not None:
        comments[swing] = (f"{r.sensor}'s difference leaving its {SWING_S / 60:g}-min mean by more than this sets "
                           f"SensorsDisagree, K: {MARGIN:g} x the largest swing recorded, {r.largest_swing_K:.3g} "
                           f"K, rounded up" + (f", at least {GATE_FLOOR_K:g} K" if r.swing_K[0] <= GATE_FLOOR_K
                                               else ""))
        comments[swing_quiet] = f"{r.sensor}'s swing inside this (half its gate) counts as steady again, K"
        comments[SWING_KEEP] = (f"share of its slow mean each difference's mean keeps per call: "
                                f"exp(-{model.sample_period_s:g} s / {SWING_S:g} s)")
        comments[SWING_ALPHA] = (f"share of each new difference the slow means take per call: "
                                 f"1 - exp(-{model.sample_period_s:g} s / {SWING_S:g} s)")
    return comments


def _refuse_unread_inputs(model: Model, core: Block) -> None:
    """Every input of the model file must be one the kind's block reads: the guards would check an
    input the block never declares (a speed on an mlr model, say), so the file is refused by name."""
    declared = {v.name for v in core.inputs}
    for k, s in enumerate(model.inputs):
        if s.name not in declared:
            raise GenerationError(f"field 'inputs[{k}]': input {s.name!r} has role {s.role!r}, which a {model.kind} "
                                  f"block does not read (it reads {', '.join(v.name for v in core.inputs)}); remove "
                                  f"the input from the file, or is 'kind' right?")


def prove(model: Model, block: Block, limits: Limits) -> RangeProof:
    """The static range proof of `block` with every input anywhere in its guard range and Reset either
    way. Enable is taken TRUE: a disabled call writes ENO and nothing else (with_commissioning gates
    every other region), so it keeps any state the proof finds."""
    constants = limits.values()
    ranges = {g.name: (constants[g.low], constants[g.high]) for g in guards(model)}
    if model.probe is not None:  # a probing beyond the limit is refused before any arithmetic reads it
        limit = model.probe.values()["limit_um"]
        ranges[PROBE_VALUE_INPUT] = (-limit, limit)
    return prove_ranges(block, {**ranges, ENABLE_INPUT: True}, partition=("Init", READY_OUTPUT))
