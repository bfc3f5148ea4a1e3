"""A fused block's probing inputs in a replay: from explicit columns named like the block inputs (ProbeValue,
ProbeNew, or mapped with --inputs), else from the target's own measured rows (a probed or held target), else
simulated every N calls (`--probe-every N`) on a target measured at every call (models/probing.probings)."""
from __future__ import annotations

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.base.values import Every
from thermoplc.contract.outputs import PROBE_INPUTS, PROBE_NEW_INPUT, PROBE_VALUE_INPUT
from thermoplc.recordings.campaign import held_to_probed
from thermoplc.models.model import Model
from thermoplc.models.probing import needs_schedule, probings, rising
from thermoplc.recordings.table import Table
from thermoplc.verifier.engines.typed import cells_as


def probing_inputs(model: Model, table: Table, overrides: dict | None = None, every: int | Every | None = None) -> dict:
    """ProbeValue and ProbeNew per call by block input name; empty for a static model. `every` (calls, or a
    duration in the block's cycles) defaults to the schedule the model was fitted with (metrics.probing)."""
    if model.probe is None:
        if every is not None:
            raise UserError(f"--probe-every {every}: the model has no probe fusion (fit it with --probe)")
        return {}
    if isinstance(every, Every):
        every = every.calls_at(model.sample_period_s)
    overrides = overrides or {}
    columns = {name: overrides.get(name, name) for name in PROBE_INPUTS.values()}
    given = [name for name, column in columns.items() if column in table.columns]
    if given:
        if len(given) != 2 or every is not None:
            raise UserError(f"{table.path}: the probing is read from columns {', '.join(columns.values())} together "
                            f"(found {', '.join(columns[n] for n in given)}); give both, without --probe-every")
        return {name: cells_as(table, column, "REAL" if name == PROBE_VALUE_INPUT else "BOOL",
                               f"input {name}") for name, column in columns.items()}
    probing = model.metrics.get("probing", {})
    return from_target(table, model.target.column, every, bool(probing.get("held")), probing.get("every_calls"))


def from_target(table: Table, column: str, every: int | None, held: bool, recorded: int | None = None) -> dict:
    """ProbeValue and ProbeNew per call from the target `column`: its measured rows (probed, or `held` between
    probings), or a probing every `every` calls of a target measured at every call (by default every `recorded`
    calls, the schedule the model was fitted with)."""
    if column not in table.columns:
        raise UserError(f"{table.path}: no column {column!r} (the target) nor {PROBE_VALUE_INPUT} and "
                        f"{PROBE_NEW_INPUT} to replay the probings from")
    if held:
        table = held_to_probed(table, column)
    target = table.column(column)
    if every is None and needs_schedule(target) and recorded:
        every = int(recorded)
    if every is None and needs_schedule(target):
        raise UserError(f"{table.path}: column {column!r} is measured at every call, so which calls are "
                        f"probings is not in the data; give --probe-every N (a probing every N calls) or columns "
                        f"{PROBE_VALUE_INPUT} and {PROBE_NEW_INPUT}")
    if every is not None and not needs_schedule(target):
        raise UserError(f"--probe-every {every}: column {column!r} of {table.path} is probed (empty "
                        f"between its measurements), and its measured rows are the probings; leave --probe-every out")
    value, new = probings(target, every)
    if every is not None and not new.any():
        raise UserError(f"--probe-every {every}: {table.path} has {table.rows} calls, so no probing would be replayed "
                        f"and the fusion not exercised; give a shorter schedule")
    return {PROBE_VALUE_INPUT: value, PROBE_NEW_INPUT: new}


def with_probings(table: Table, column: str, every: int | None, held: bool) -> Table:
    """`table` with columns ProbeValue and ProbeNew from its target `column`, for a replay that maps block inputs
    to columns by name (diff); refused where the table has such columns already."""
    taken = [name for name in PROBE_INPUTS.values() if name in table.columns]
    if taken:
        raise UserError(f"{table.path}: has column {taken[0]} already; the probings come from it, not from "
                        f"--probe-target (leave --probe-target and --probe-every out)")
    found = from_target(table, column, every, held)
    return Table(table.path, {**table.columns, **{k: np.asarray(v, float) for k, v in found.items()}}, table.sha256,
                 table.lines)


def start_value_errors(inputs) -> list[str]:
    """The probing inputs' declared start values against the contract (ProbeNew FALSE: unwired, no probing
    ever; ProbeValue none: it must be wired). A replay drives both, so only this check sees them."""
    errors = []
    for d in inputs:
        if d.name.upper() == PROBE_NEW_INPUT.upper() and d.initial not in (None, False):
            errors.append(f"{d.name}: start value {d.initial!r}, the contract's is FALSE (an unwired ProbeNew must "
                          f"never make a probing)")
        if d.name.upper() == PROBE_VALUE_INPUT.upper() and d.initial is not None:
            errors.append(f"{d.name}: start value {d.initial!r}, the contract gives it none (it must be wired)")
    return errors


def reference_keys(block_inputs: dict) -> dict:
    """The probing inputs under the reference's keys."""
    return {key: block_inputs[name] for key, name in PROBE_INPUTS.items() if name in block_inputs}


def summary(block_inputs: dict) -> str:
    """How many probings the replay gave the block; none is said as what it means."""
    if not block_inputs:
        return ""
    edges = int(np.count_nonzero(rising(block_inputs[PROBE_NEW_INPUT])))
    if not edges:
        return f"probings replayed: 0 - the data holds no probing, so the fusion was not exercised (its constants were)"
    return f"probings replayed: {edges} (rising edges of {PROBE_NEW_INPUT})"
