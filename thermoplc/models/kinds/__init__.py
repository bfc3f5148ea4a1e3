"""Every model kind, one module each in this package (its record, `models/kind.py`, its fit and its float32
reference): the single list the schema enum, the CLI choices, the golden files and every dispatch are derived
from. Adding a kind is a new module here (and its lowering in the generator), nothing else. The registry loads
the modules of this package only: the model file, the references and the safety logic beside it import the
registry, so loading them from it would close a circle at run time."""
from __future__ import annotations

import functools
import importlib
import pkgutil

from thermoplc.base.errors import UserError
from thermoplc.models.kind import Kind, KindOption, guard_kind


@functools.cache
def registry() -> dict[str, Kind]:
    """Kind name -> record, in the papers' order."""
    found: dict[int, Kind] = {}  # by identity: a module that imports another's record holds it too
    for module in pkgutil.iter_modules(__path__):
        loaded = importlib.import_module(f"{__name__}.{module.name}")
        found.update({id(value): value for value in vars(loaded).values() if isinstance(value, Kind)})
    kinds = sorted(found.values(), key=lambda kind: kind.order)
    named = {kind.name: kind for kind in kinds}
    if len(named) != len(kinds):
        raise RuntimeError(f"two model kinds share a name: {sorted(kind.name for kind in kinds)}")
    return named


def names() -> tuple[str, ...]:
    return tuple(registry())


@functools.cache
def options() -> dict[str, KindOption]:
    """Every kind's own options by field, in the papers' order of the kinds that declare them; kinds that read
    the same option declare the same record."""
    found: dict[str, KindOption] = {}
    for kind in registry().values():
        for option in kind.options:
            if found.setdefault(option.field, option) != option:
                raise RuntimeError(f"option {option.field!r} is declared two ways: by {kind.name} and before it")
    return found


def readers(field: str) -> tuple[Kind, ...]:
    """The kinds whose fit reads this FitRequest field or option (Kind.reads), in the papers' order."""
    return tuple(kind for kind in registry().values() if kind.reads(field))


def kind_of(name: str) -> Kind:
    if name not in registry():
        raise UserError(f"no model kind {name!r}; the kinds are {', '.join(registry())}")
    return registry()[name]


def driving_temperatures(model) -> list[str]:
    """The checked temperatures that drive the machine rather than follow it: the ambient. The hall air sets the
    machine's temperatures through hours of lag, so no static relation ties it to them (FL_THERMAL's first 6 h,
    held out, left the relation the other runs taught the machine's sensors and the ambient by 80 % of its calls)."""
    return [s.name for s in model.inputs if "ambient" in s.role.split(",")]


def checked_temperatures(model) -> list[str]:
    """The temperatures the cross-sensor check reads (models/plausibility.py), in block order: every temperature
    input, as the block holds it or, where a filter judges its own (the Kalman filter), as last read in range."""
    fused = kind_of(model.kind).fused_guards
    return [s.name for s in model.inputs if guard_kind(s.role, fused) in ("temperature", "fused")]
