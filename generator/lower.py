"""Models -> block IR. The expression trees are the operation order the references follow;
each kind's lowering lives in its own module, this one picks it and adds the safety logic."""
from __future__ import annotations

import functools
import importlib
import pkgutil
from dataclasses import replace

from thermoplc.generator.commissioning import with_commissioning
from thermoplc.generator.ir import Block, GenerationError, Identity
from thermoplc.generator.ranges import RangeProof, prove_ranges
from thermoplc.generator.safety import with_safety
from thermoplc.models.modelfile import Model
from thermoplc.models.safety import ENABLE, Limits, axis_outputs, guards



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


def lower(model: Model, limits: Limits = Limits(), identity: Identity | None = None, retain: bool = False) -> Block:
    """The block for `model`, inside the input guards and output limits every block carries, with
    Enable/ENO and Reset; `identity` defaults to the version the model's fingerprint gives."""
    core = lower_model(model)
    axes = axis_outputs(model, [v.name for v in core.outputs if v.type == "REAL"])
    block = with_commissioning(with_safety(core, guards(model), axes, limits))
    return replace(block, identity=identity or model_identity(model), retain=retain)


def model_identity(model: Model, date: str = "") -> Identity:
    """The block version tied to the model: the first two hex digits of its fingerprint (0.0 to 15.15,
    the range TIA and STEP 7 take), so a changed model shows a changed version in the block properties."""
    fingerprint = model.fingerprint()
    return Identity(version=(int(fingerprint[0], 16), int(fingerprint[1], 16)), date=date)


def prove(model: Model, block: Block, limits: Limits) -> RangeProof:
    """The static range proof of `block` with every input anywhere in its guard range and Reset either
    way. Enable is taken TRUE: a disabled call writes ENO and nothing else (with_commissioning gates
    every other region), so it keeps any state the proof finds."""
    constants = limits.constants()
    ranges = {g.name: (constants[g.low], constants[g.high]) for g in guards(model)}
    return prove_ranges(block, {**ranges, ENABLE: True}, partition=("Init", "Ready"))
