"""The named physical effects (docs/diagnosis.md), found in the modules of this package that
declare one (`EFFECT = EffectDefinition(...)`, see `definition.py`): the single list the twin's
`--effect`, the model file, the simulation's bookkeeping and the diagnosis read. Adding an effect
is a new module here (its term: a displacement term, a heat input, the search of its shared
parameters, a closed loop or a reading's column, as its record declares; the simulation and the
identified model call them), its per-call arithmetic in the reference's one loop
(`models/lumped_kernel.py`, its flag in `models/kinds/lumped_model.py`) and in the block (a module of
`generator/lumped_effects/`), and its physics in each synthetic machine."""
from __future__ import annotations

import functools
import importlib
import pkgutil
from dataclasses import dataclass

from thermoplc.base.errors import UserError
from thermoplc.physics.effects.definition import EffectDefinition

__all__ = ["NAMES", "Effect", "EffectDefinition", "definition_of", "registry", "with_part"]


@functools.cache
def registry() -> dict[str, EffectDefinition]:
    """Effect name -> record, by rank."""
    found = []
    for module in pkgutil.iter_modules(__path__):
        loaded = importlib.import_module(f"{__name__}.{module.name}")
        record = getattr(loaded, "EFFECT", None)
        if isinstance(record, EffectDefinition):
            found.append(record)
    found.sort(key=lambda record: record.rank)
    named = {record.name: record for record in found}
    if len(named) != len(found) or len({record.rank for record in found}) != len(found):
        raise RuntimeError(f"two effects share a name or a rank: {[(r.rank, r.name) for r in found]}")
    return named


@dataclass(frozen=True)
class Effect:
    """A named effect with its parameters (defaults filled in)."""
    name: str
    parameters: tuple[tuple[str, float | str], ...]

    def get(self, key: str):
        return dict(self.parameters)[key]

    @staticmethod
    def parse(text: str, columns: dict[str, str] | None = None) -> "Effect":
        """NAME[:key=value,...]; `columns` names the sensor an effect with a `column` lands on
        unless told (each machine has its own sensors)."""
        name, _, rest = text.partition(":")
        name = name.strip()
        if name not in registry():
            raise UserError(f"--effect {text!r}: unknown effect {name!r}; expected one of {', '.join(registry())}")
        return Effect(name, registry()[name].parameters_from(text, rest, columns))


def definition_of(name: str) -> EffectDefinition:
    return registry()[name]


def with_part(part: str) -> frozenset[str]:
    """The names of the effects that extend this part of the simulation."""
    return frozenset(name for name, record in registry().items() if record.part == part)


def __getattr__(attribute: str):
    """`NAMES`, the effect names by rank, found on first use (PEP 562): importing this package
    loads no effect module."""
    if attribute == "NAMES":
        return tuple(registry())
    raise AttributeError(f"module {__name__!r} has no attribute {attribute!r}")
