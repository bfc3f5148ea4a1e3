"""The block's names of the model's per-input outputs: each sensor's fault bit.

The models key an input's per-call fault flags by `models.kind.fault_key(input)`, no ST name. The
block declares them as `Fault_<input>` (`Fault_T_motor`) when that is an identifier within the
limits every dialect keeps (base/identifiers.py: 24 characters) and unique, ignoring case, among
the model's names and the other fault bits; otherwise `Fault_<i>`, i the input's 1-based position
among the block inputs. The generator names the outputs by this rule, the verifier reads the
block's outputs back by it.

Blocks generated before this rule named every fault bit `Fault_<i>`. The verifier still proves
them against the model: `block_names` takes that naming when a block declares it (same bits, only
the names differ); `diff` between such a block and a new one shows the renamed outputs.
"""
from __future__ import annotations

from typing import Iterable

from thermoplc.base.identifiers import identifier_problem
from thermoplc.models.kind import fault_key
from thermoplc.models.modelfile import Model
from thermoplc.models.safety import guards

FAULT_PREFIX = "Fault_"


def _model_names(model: Model) -> set[str]:
    """The model's own names in the block (inputs and outputs), as ST compares them."""
    names = [*(s.name for s in model.inputs), model.target.name, *(t["name"] for t in model.settings.get("targets", ()))]
    return {name.upper() for name in names}


def fault_outputs(model: Model) -> dict[str, str]:
    """Block input -> the name of its fault bit (module docstring), in the block's input order."""
    taken = _model_names(model)
    out = {}
    for guard in guards(model):
        name = FAULT_PREFIX + guard.name
        if identifier_problem(name) is not None or name.upper() in taken:
            name = f"{FAULT_PREFIX}{guard.index}"
        taken.add(name.upper())
        out[guard.name] = name
    return out


def numbered_fault_outputs(model: Model) -> dict[str, str]:
    """The fault bits as blocks generated before the sensor names had them: `Fault_<i>` for every input."""
    return {guard.name: f"{FAULT_PREFIX}{guard.index}" for guard in guards(model)}


def block_names(model: Model, declared: Iterable[str] = ()) -> dict[str, str]:
    """Reference key -> block output name for the keys the models do not name as the block does
    (the fault flags): by the current rule, or by the numbered one when the block `declared`
    (its outputs, when known) has every numbered fault bit and not the current names."""
    current, numbered = fault_outputs(model), numbered_fault_outputs(model)
    have = {name.upper() for name in declared}
    if have and current != numbered and all(n.upper() in have for n in numbered.values()) \
            and not any(n.upper() in have for n in set(current.values()) - set(numbered.values())):
        current = numbered
    return {fault_key(name): output for name, output in current.items()}


def named(reference: dict, names: dict[str, str]) -> dict:
    """The reference's outputs under the block's names (`names` from block_names), in their order."""
    return {names.get(key, key): values for key, values in reference.items()}
