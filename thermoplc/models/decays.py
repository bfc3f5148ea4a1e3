"""Every lag of a `lumped` model file decays: checked at load, before a block is built or run."""
from __future__ import annotations

import re

from thermoplc.base.errors import UserError
from thermoplc.models.model import Model
from thermoplc.physics.displacement import displacement_terms

PER_SENSOR_DECAY = re.compile(r"(A|As)_\d+")
PER_SENSOR_COMPLEMENT = re.compile(r"(B|Bs)_\d+")
PAIR_SUM_TOLERANCE = 1e-9  # each half is 1 float64 rounding from its exact value
SHARED_PAIRS = {"AS": "BS", "AGr": "BGr", "ACl": "BCl"}  # the structure's, the gear heat's and the cooling's lags
# (the displacement terms add theirs)


def _complement_of(decay: str, shared: dict) -> str:
    """B_1 for A_1, Bs_2 for As_2, the shared pair's other half for AS, AGr, ..."""
    if decay in shared:
        return shared[decay]
    stem, _, sensor = decay.partition("_")
    return f"{'B' if stem == 'A' else 'Bs'}_{sensor}"


def check(model: Model, path: str) -> None:
    """Each lag's decay per call a = exp(-dt/tau) lies in [0, 1) and its complement 1 - a in (0, 1], and the two
    add up to 1: a decay of 1 or more integrates its input without bound (the block's state grows until it
    overflows), a negative one makes the state ring, a pair that does not add up to 1 scales what it lags."""
    shared = {**SHARED_PAIRS, **{term.pole[0]: term.pole[1] for term in displacement_terms()}}
    pairs = []
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
        if decay:
            pairs.append((name, _complement_of(name, shared)))
    for decay, other in pairs:
        value = model.coef(decay, "f64")
        if other in model.coefficients and abs(value + model.coef(other, "f64") - 1.0) > PAIR_SUM_TOLERANCE:
            raise UserError(f"{path}: field 'coefficients.{other}': {model.coef(other, 'f64')!r}, but 1 - {decay} is "
                            f"{1.0 - value!r}: a lag's decay and its complement add up to 1 (the lag's gain), "
                            f"each rounded once")
