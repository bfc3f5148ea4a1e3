"""Enable and Reset as the data drive them: read by the block's input names, handed to the
reference under its own keys (contract/outputs.py), summarised for the report."""
from __future__ import annotations

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.contract.outputs import CONTROL_INPUT_START, ENABLE_INPUT, RESET_INPUT
from thermoplc.recordings.table import Table, close_match, spellings


def control_inputs(table: Table, overrides: dict | None = None) -> dict:
    """Enable and Reset per call from the data, by input name: a column named like the input, in any case
    as ST names are (or mapped with --inputs Enable=COLUMN), holding 0 or 1; an input without a column
    keeps its start value."""
    overrides = overrides or {}
    control = {}
    for name in CONTROL_INPUT_START:
        column = control_column(table, name, overrides)
        if column in table.columns:
            values = table.columns[column]
            bad = ~np.isin(values, (0.0, 1.0))
            if bad.any():
                table.refuse_cell(column, bad, f"the {name} input (BOOL)", "0 or 1")
            control[name] = values == 1.0
        elif name in overrides:
            raise UserError(f"{table.path}: no column {column!r} for block input {name!r}"
                            f"{close_match(column, table.columns)}; the header has {', '.join(table.columns)}")
    return control


def control_column(table: Table, name: str, overrides: dict | None = None) -> str:
    """The column of control input `name`: mapped by --inputs, else named like it in any case (`enable`);
    refuses two."""
    if (overrides or {}).get(name):
        return overrides[name]
    found = spellings(table.columns, name)  # an exact one does not win: 'Enable' and 'enable' both name it
    if len(found) > 1:
        raise UserError(f"{table.path}: columns {', '.join(found)} could each drive the block input {name}; "
                        f"choose one with --inputs {name}=COLUMN")
    return found[0] if found else name


def control_summary(control: dict, rows: int) -> str:
    """What the data asked of Enable and Reset; a recording in which the block never ran says so."""
    if not control:
        return ""
    enable = control.get(ENABLE_INPUT, np.ones(rows, bool))
    enabled = int(np.count_nonzero(enable))
    resets = int(np.count_nonzero(control.get(RESET_INPUT, np.zeros(rows, bool)) & enable))
    if enabled == 0:
        return "Enable is FALSE on every call: the block never ran, so only its held start values were compared"
    return (f"Enable and Reset from the data: enabled on {enabled} of {rows} calls, {resets} reset call(s) "
            f"(a Reset on a disabled call does nothing)")


def unread_control_columns(table: Table, inputs) -> str:
    """A note when the data has an Enable or Reset column but the block no such input (a hand-written block
    compared with a trace): the column is not read, and the user should know the replay ran every call."""
    declared = {d.name.upper() for d in inputs}
    named = {name: spellings(table.columns, name) for name in CONTROL_INPUT_START if name.upper() not in declared}
    unread = [column for columns in named.values() for column in columns]
    if not unread:
        return ""
    missing = " or ".join(name for name, columns in named.items() if columns)
    shown = ", ".join(repr(c) for c in unread)
    return (f"{'columns' if len(unread) > 1 else 'column'} {shown} of the data not read: the block has no {missing} "
            f"input, so every call ran as written")
