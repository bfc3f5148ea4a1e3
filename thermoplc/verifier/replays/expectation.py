"""What a block must output over a recording: the block's inputs per call and the float32 reference's
outputs under the block's names, as verify compares them and as a test bench holds them."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.contract.outputs import (CONTROL_INPUT_START, PROBE_INPUT_START, PROBE_INPUTS, RESET_INPUT, block_names,
                                       control_of, named)
from thermoplc.models.model import Model
from thermoplc.models.reference import block_outputs, model_inputs
from thermoplc.models.safety import Limits
from thermoplc.recordings.table import Table
from thermoplc.verifier.replays.control import control_inputs
from thermoplc.verifier.engines.choice import Replayer
from thermoplc.verifier.replays.mapping import known_overrides
from thermoplc.verifier.replays.probings import probing_inputs, reference_keys
from thermoplc.verifier.reading.syntax import Program


@dataclass(frozen=True)
class Expectation:
    """A block read, its inputs per call from the data (by block input name) and the reference's outputs."""
    program: Program
    replayer: Replayer
    limits: Limits
    inputs: dict  # the model's inputs, float32
    control: dict  # Enable and Reset where the data drive them
    probing: dict  # ProbeValue and ProbeNew of a fused block
    expected: dict  # block output name -> the float32 reference's values

    @property
    def columns(self) -> dict:
        return {**self.inputs, **self.control, **self.probing}


def check_interface(machine, block: str, available: dict, what: str) -> None:
    """Every block input without a start value has a column in `what`, and `what` has no column the block
    lacks: a misspelt column would otherwise leave an input at its start value for the whole replay."""
    names = {d.name.upper() for d in machine.inputs}
    missing = sorted(d.name for d in machine.inputs if d.name not in available and d.initial is None)
    extra = sorted(n for n in available if n.upper() not in names)
    if missing or extra:
        raise UserError(f"{block}: block inputs {', '.join(d.name for d in machine.inputs)} do not match {what}"
                        + (f"; no value for {', '.join(missing)}" if missing else "")
                        + (f"; {what} also has {', '.join(extra)}" if extra else ""))


def check_model_inputs(machine, block: str, model: Model, source: str) -> None:
    """Every input the model file lists must be an input of the block: a block generated from the file
    reads each one (generate refuses an input its kind does not read), so the file and the block
    belong to different models, or the file was edited."""
    declared = {d.name.upper() for d in machine.inputs}
    for k, s in enumerate(model.inputs):
        if s.name.upper() not in declared:
            raise UserError(f"{source}: field 'inputs[{k}]': input {s.name!r} (role {s.role!r}) is not an input of "
                            f"{block} (its inputs: {', '.join(d.name for d in machine.inputs)}); was the model file "
                            f"edited, or is the block another model's?")


def mistyped(machine, reference: dict):
    """The first input or output the block declares with another type than the model's block has
    (BOOL outputs, Enable/Reset and ProbeNew, INT counters, REAL the rest, no arrays), with that type; or None."""
    kinds = {"b": "BOOL", "i": "INT"}
    wanted = {**{name: kinds.get(np.asarray(values).dtype.kind, "REAL") for name, values in reference.items()},
              **dict.fromkeys(CONTROL_INPUT_START, "BOOL"), **dict.fromkeys(PROBE_INPUT_START, "BOOL")}
    for d in (*machine.outputs, *machine.inputs):
        expected = wanted.get(d.name, "REAL")
        if d.type.base != expected or d.type.bounds:
            return d, expected
    return None


def reference_outputs(model: Model, limits: Limits, columns: dict, declared: list[str]) -> dict:
    """The float32 reference's outputs under the block's names for block input columns `columns`."""
    reference_inputs = {**{s.name: columns[s.name] for s in model.inputs}, **reference_keys(columns)}
    control = control_of({name: columns[name] for name in CONTROL_INPUT_START if name in columns})
    return named(block_outputs(model, reference_inputs, "f32", limits, control), block_names(model, declared))


def model_expectation(block: str, program: Program, replayer: Replayer, limits: Limits, model: Model, model_path: str,
                      table: Table, overrides: dict | None, probe_every) -> Expectation:
    """The inputs and the reference outputs of `block` over `table`, or a UserError naming what does not match."""
    check_model_inputs(replayer, block, model, model_path)
    probe_names = PROBE_INPUTS.values() if model.probe is not None else ()
    overrides = known_overrides(overrides, [*(s.name for s in model.inputs), *CONTROL_INPUT_START, *probe_names],
                                model_path)
    inputs = model_inputs(model, table, overrides)
    control = control_inputs(table, overrides)
    probing = probing_inputs(model, table, overrides, probe_every)
    check_interface(replayer, block, {**inputs, **control, **probing}, f"the inputs of {Path(model_path).name}")
    declared = [d.name for d in replayer.outputs]
    expected = reference_outputs(model, limits, {**inputs, **control, **probing}, declared)
    unknown = [name for name in declared if name not in expected]
    missing = [name for name in expected if name not in declared]
    if unknown or missing:
        raise UserError(f"{block}: block outputs {', '.join(declared)} do not match the outputs of "
                        f"{Path(model_path).name}: {', '.join(expected)}")
    wrong = mistyped(replayer, expected)
    if wrong:
        d, kind = wrong
        raise UserError(f"{block}:{d.pos[0]}:{d.pos[1]}: {d.name} is declared {d.type.base}; the model's block "
                        f"has it as {kind}")
    return Expectation(program, replayer, limits, inputs, control, probing, expected)


def window(expectation: Expectation, model: Model, first: int, calls: int) -> tuple[dict, dict]:
    """Every block input's values and the reference's outputs for calls `first` .. `first + calls - 1` of
    the data, the block Reset at the window's first call (a new instance's state, wherever it starts)."""
    columns = {}
    for d in expectation.replayer.inputs:
        values = expectation.columns.get(d.name)
        if values is None:  # unwired: its start value at every call
            values = np.full(first + calls, d.initial, bool if d.type.base == "BOOL" else np.float32)
        columns[d.name] = np.array(values[first:first + calls])
    if RESET_INPUT in columns:
        columns[RESET_INPUT][0] = True
    declared = list(expectation.expected)
    return columns, reference_outputs(model, expectation.limits, columns, declared)
