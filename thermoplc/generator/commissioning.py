"""What a PLC engineer needs around the model: an Enable input with the dialect's ENO, a Reset input.

Enable FALSE skips the whole call, as a Siemens block called with EN = FALSE would be: the state
does not advance, the outputs keep their values and ENO reads FALSE. A call with Reset TRUE starts
the block afresh, as a new instance would - every state variable and flag back to its start value,
the references latched again once every input is in range - except the limited outputs, which the
rate limiter then moves from where they are (the axis must not jump). Knows the IR, not the models;
models/safety.py computes the same per call.
"""
from __future__ import annotations

from dataclasses import replace

from thermoplc.generator.ir import (
    ENO, Assign, BinOp, Block, BoolConst, Const, For, GenerationError, If, IntConst, Ref, Region, Stmt, Var,
    assigned_names,
)
from thermoplc.contract.outputs import CONTROL_INPUT_START, ENABLE_INPUT, RESET_INPUT

RESET_INDEX = "ResetIdx"
ZERO = "c_Zero"


def _restart(block: Block, assigned: set) -> tuple[tuple[Stmt, ...], bool]:
    """Statements that put the state back to its start values; whether they need the REAL zero."""
    stmts: list[Stmt] = []
    needs_zero = False
    start = {"REAL": Ref(ZERO), "INT": IntConst(0), "BOOL": BoolConst(False)}
    for v in (*block.statics, *block.outputs):
        if v.name not in assigned or (v in block.outputs and v.type == "REAL"):
            continue
        needs_zero |= v.type == "REAL"
        if v.length is None:
            stmts.append(Assign(v.name, start[v.type]))
        else:
            stmts.append(For(RESET_INDEX, IntConst(0), IntConst(v.length - 1),
                             (Assign(v.name, start[v.type], Ref(RESET_INDEX)),)))
    return tuple(stmts), needs_zero


def _gated(region: Region) -> Region:
    """The region, run only when Enable is TRUE (one IF: a region that is one IF gets Enable AND its test)."""
    body = region.body
    if len(body) == 1 and isinstance(body[0], If) and len(body[0].branches) == 1 and not body[0].orelse:
        cond, stmts = body[0].branches[0]
        return Region(region.title, (If(((BinOp("AND", Ref(ENABLE_INPUT), cond), stmts),)),))
    return Region(region.title, (If(((Ref(ENABLE_INPUT), body),)),))


def with_commissioning(block: Block) -> Block:
    """`block` with Enable, Reset and ENO (see the module docstring)."""
    assigned = set(assigned_names(block.regions))
    restart, needs_zero = _restart(block, assigned)
    commission = Region("Enable (ENO) and Reset: a reset call starts the block as a new instance would", (
        Assign(ENO, Ref(ENABLE_INPUT)),
        If(((BinOp("AND", Ref(ENABLE_INPUT), Ref(RESET_INPUT)), restart),)),
    ))
    constants = block.constants
    zero = next((c for c in constants if c.name == ZERO), None)
    if needs_zero and zero is None:
        constants = (*constants, Const(ZERO, 0.0, "start value of the state (Reset)"))
    elif zero is not None and zero.value != 0.0:
        raise GenerationError(f"{ZERO} is {zero.value!r}; the reset needs it to be 0.0")
    temps = block.temps
    if any(isinstance(s, For) for s in restart):
        temps = (*temps, Var(RESET_INDEX, "INT", "array index while the state is reset"))
    inputs = (*block.inputs,
              Var(ENABLE_INPUT, "BOOL", "FALSE: the call is skipped (state frozen, outputs held, ENO FALSE)",
                  initial=CONTROL_INPUT_START[ENABLE_INPUT]),
              Var(RESET_INPUT, "BOOL", "TRUE: restart as a new instance, latching the temperatures as the cold "
                  "reference - only with the machine at ambient; not a fault acknowledge",
                  initial=CONTROL_INPUT_START[RESET_INPUT]))
    outputs = (*block.outputs, Var(ENO, "BOOL", "Enable of this call"))
    return replace(block, inputs=inputs, outputs=outputs, temps=temps, constants=constants,
                   regions=(commission, *(_gated(r) for r in block.regions)))

