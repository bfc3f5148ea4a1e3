"""What each named effect adds to the lumped-mass block: one module per effect that has block
arithmetic (`LOWERING = EffectLowering(...)`, see `lowering.py`), found by scanning this package.
An effect without one (sensor_drift: the reading's drift is not compensated in the block; sensor_offset,
whose O_i the baseline subtracts wherever the model file has one) adds nothing of its own."""
from __future__ import annotations

import functools
import importlib
import pkgutil

from thermoplc.generator.lumped_effects.lowering import EffectLowering, Lumped, Speed, State, lag
from thermoplc.physics.effects import registry

__all__ = ["EffectLowering", "Lumped", "Speed", "State", "lag", "lowerings", "of_model"]


@functools.cache
def lowerings() -> dict[str, EffectLowering]:
    """Effect name -> its block lowering, in the effects' rank order."""
    found = {}
    for module in pkgutil.iter_modules(__path__):
        record = getattr(importlib.import_module(f"{__name__}.{module.name}"), "LOWERING", None)
        if isinstance(record, EffectLowering):
            if record.name not in registry():
                raise RuntimeError(f"{module.name}: lowering of unknown effect {record.name!r}")
            found[record.name] = record
    return {name: found[name] for name in registry() if name in found}


def of_model(names) -> tuple[EffectLowering, ...]:
    """The lowerings of these effects, in rank order (the block's order does not follow the file's)."""
    wanted = set(names)
    return tuple(record for name, record in lowerings().items() if name in wanted)
