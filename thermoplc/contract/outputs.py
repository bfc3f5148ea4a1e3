"""The block's names for what the models key otherwise: each sensor's fault bit, the status flags,
the K0 outputs and the commissioning inputs.

The status flags, K0 and Enable/Reset have fixed names: Ready, Limited, Clamped, Invalid, SensorsDisagree,
ENO (the dialect's enable output), K0_<k> for the k-th output in um, Enable and Reset.

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
from thermoplc.models.model import Model
from thermoplc.models.plausibility import DISAGREE
from thermoplc.models.probing import PROBE_NEW, PROBE_VALUE, REFUSALS, REFUSED, SUSPECT, USED
from thermoplc.models.safety import (CLAMPED, CONTROL_START, ENABLE, ENABLED, INVALID, LIMITED, READY, RESET,
                                     guards, k0_key)

FAULT_PREFIX = "Fault_"
ENO, READY_OUTPUT, LIMITED_OUTPUT, CLAMPED_OUTPUT, INVALID_OUTPUT = "ENO", "Ready", "Limited", "Clamped", "Invalid"
PROBE_USED_OUTPUT, PROBE_REFUSED_OUTPUT, PROBE_REFUSALS_OUTPUT = "ProbeUsed", "ProbeRefused", "ProbeRefusals"
PROBE_SUSPECT_OUTPUT = "ProbeSuspect"
DISAGREE_OUTPUT = "SensorsDisagree"
STATUS_OUTPUTS = {READY: READY_OUTPUT, LIMITED: LIMITED_OUTPUT, CLAMPED: CLAMPED_OUTPUT, INVALID: INVALID_OUTPUT,
                  ENABLED: ENO, USED: PROBE_USED_OUTPUT, REFUSED: PROBE_REFUSED_OUTPUT,
                  REFUSALS: PROBE_REFUSALS_OUTPUT, SUSPECT: PROBE_SUSPECT_OUTPUT,
                  DISAGREE: DISAGREE_OUTPUT}  # reference key -> block output
# a fused block's probing inputs (models/probing.py): the value, um, and the BOOL whose rising edge is a new probing
PROBE_VALUE_INPUT, PROBE_NEW_INPUT = "ProbeValue", "ProbeNew"
PROBE_INPUTS = {PROBE_VALUE: PROBE_VALUE_INPUT, PROBE_NEW: PROBE_NEW_INPUT}  # reference key -> block input
PROBE_INPUT_START = {PROBE_NEW_INPUT: False}  # unwired: no probing ever arrives (ProbeValue must be wired)
ENABLE_INPUT, RESET_INPUT = "Enable", "Reset"
CONTROL_INPUTS = {ENABLE: ENABLE_INPUT, RESET: RESET_INPUT}  # reference key -> block input
CONTROL_INPUT_START = {CONTROL_INPUTS[key]: start for key, start in CONTROL_START.items()}  # unwired, by input name
K0_PREFIX = "K0_"


def output_unit(output: str) -> str:
    """A REAL output's unit as the block's names say it: K0 in mm, an angle in urad, a displacement in um."""
    return "mm" if output.startswith(K0_PREFIX) else "urad" if "urad" in output.lower() else "um"


def k0_output(axis: int) -> str:
    """The block's K0 output (SD43900, mm) of the `axis`-th output in um, counted from 1."""
    return f"{K0_PREFIX}{axis}"


def control_of(block_inputs: dict) -> dict:
    """Enable and Reset per call by the block's input names -> the same under the reference's keys."""
    return {key: block_inputs[name] for key, name in CONTROL_INPUTS.items() if name in block_inputs}


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
    """The reference's outputs under the block's names (`names` from block_names; the status flags and K0
    by their fixed names; the model's outputs by their own), in their order."""
    k0 = {k0_key(axis): k0_output(axis) for axis in range(1, len(reference) + 1)}
    return {names.get(key) or STATUS_OUTPUTS.get(key) or k0.get(key, key): values for key, values in reference.items()}
