"""Every lag of a `lumped` model file decays: checked at load, before a block is built or run."""
from __future__ import annotations

import re

from thermoplc.base.errors import UserError
from thermoplc.models.model import Model
from thermoplc.physics.displacement import displacement_terms

PER_SENSOR_DECAY = re.compile(r"(A|As)_\d+")
PER_SENSOR_COMPLEMENT = re.compile(r"(B|Bs)_\d+")
SHARED_PAIRS = {"AS": "BS", "AGr": "BGr", "ACl": "BCl"}  # the structure's, the gear heat's and the cooling's lags
# (the displacement terms add theirs)


def check(model: Model, path: str) -> None:
    """Each lag's decay per call a = exp(-dt/tau) lies in [0, 1) and its complement 1 - a in (0, 1]: a decay
    of 1 or more integrates its input without bound (the block's state grows until it overflows), a
    negative one makes the state ring."""
    shared = {**SHARED_PAIRS, **{term.pole[0]: term.pole[1] for term in displacement_terms()}}
    for name in model.coefficients:
        decay = bool(PER_SENSOR_DECAY.fullmatch(name)) or name in shared
        if not decay and not (PER_SENSOR_COMPLEMENT.fullmatch(name) or name in shared.values()):
            continue
        value = model.coef(name, "f64")
        if not (0.0 <= value < 1.0 if decay else 0.0 < value <= 1.0):
            raise UserError(f"{path}: field 'coefficients.{name}': {value!r}; expected "
                            + ("a decay per call exp(-dt/tau) in [0, 1)" if decay else
                               "the complement 1 - exp(-dt/tau) of a decay per call, in (0, 1]")
                            + ": a lag's state would otherwise grow without bound or ring")
