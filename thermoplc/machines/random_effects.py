"""Effect parameters drawn from physically plausible ranges, so a diagnosis is judged on more
than the defaults it was developed on (benchmarks/diagnose.py, tests).

Ranges that depend on the machine's own data (a gear threshold between the speeds it runs, coolant
thresholds inside the temperatures its spindle reaches) are read off the clean recording of the
same seed, on the rows the diagnosis trains on.
"""
from __future__ import annotations

from types import ModuleType

import numpy as np

from thermoplc.physics.effects import Effect, definition_of

def draw(name: str, machine: ModuleType, clean: dict, train_rows: int, seed: int) -> Effect:
    """`name` with parameters drawn for this machine and seed (the effect's record says from what;
    defaults for what is not drawn)."""
    rng = np.random.default_rng([seed, sum(map(ord, name))])
    values = definition_of(name).draw(rng, clean, slice(0, train_rows), machine)
    text = ",".join(f"{k}={v}" for k, v in values.items())
    return Effect.parse(f"{name}:{text}")
