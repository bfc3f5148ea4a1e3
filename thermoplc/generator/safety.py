"""Wrap a model's block in the safety logic of docs/reliability.md: input guards, start gate, output limiter.

Knows the IR, not the models: the caller says how each input is guarded (models/safety.py) and
which outputs carry a K0. The statements mirror models/safety.py operation for operation.
"""
from __future__ import annotations

from dataclasses import replace
from functools import reduce

from thermoplc.generator.ir import (
    GenerationError, Assign, BinOp, Block, BoolConst, Call, Const, If, IntConst, Ref, Region, Unary, Var, rename, walk_exprs,
)
from thermoplc.contract.constants import limit_constants, limit_name
from thermoplc.contract.outputs import (CLAMPED_OUTPUT, DISAGREE_OUTPUT, INVALID_OUTPUT, LIMITED_OUTPUT, READY_OUTPUT,
                                        k0_output)
from thermoplc.generator.fault_hold import COMMENTS as HOLD_COMMENTS, declarations as hold_declarations, hold_region
from thermoplc.generator.plausibility import Check, check_region, declarations as check_declarations
from thermoplc.generator.probing import COMMENTS as PROBE_COMMENTS, Fusion, declarations, fusion_region
from thermoplc.generator.start import CONSTANTS as START_COMMENTS, STATICS as START_STATICS, KnownStart, start_region
from thermoplc.models.safety import Guard, Limits

_CONSTANT_COMMENTS = {
    "c_TempMin": "lowest plausible temperature, degC (a broken PT100 reads -3276.8)",
    "c_TempMax": "highest plausible temperature, degC (an open PT100 reads 3276.7)",
    "c_SpeedMin": "lowest plausible speed, rpm", "c_SpeedMax": "highest plausible speed, rpm (--max-speed-rpm)",
    "c_OtherMin": "lowest plausible value of other inputs", "c_OtherMax": "highest plausible value of other inputs",
    "c_JumpMax": "temperature change per call that marks a sensor faulty, K",
    "c_SettleCalls": "steady calls before a faulty sensor is trusted again", "c_OneCall": "one call",
    "c_StuckCalls": "a temperature that repeats its reading this many times in a row is stuck (--stuck-calls)",
    "c_StepMax": "largest output change per call (--max-step-um)", "c_StepMin": "largest output change per call, downwards",
    "c_OutMax": "output clamp (--max-offset-um)", "c_OutMin": "output clamp, negative side",
    "c_K0_mm": "K0 in mm per um of error: the NC moves the axis back by the error",
    "c_RealMax": "largest REAL as S7 documents it: a model value beyond it (Inf) or unordered (NaN) is not passed on",
    **HOLD_COMMENTS,
}
# the limits generate may take from the recording: constant, what it is, the option that sets it instead
_FROM_DATA = {"max_output": ("c_OutMax", "output clamp", "--max-offset-um"),
              "max_step": ("c_StepMax", "largest output change per call", "--max-step-um"),
              "max_speed_rpm": ("c_SpeedMax", "highest plausible speed, rpm", "--max-speed-rpm"),
              "stuck_calls": ("c_StuckCalls", "a temperature that repeats its reading this many times in a row is "
                                              "stuck", "--stuck-calls")}


def _limit_comments(limits: Limits) -> dict[str, str]:
    """Each constant's comment; a limit taken from the recording says how."""
    said = {name: f"{what}: {limits.origin(field)} ({option})" for field, (name, what, option) in _FROM_DATA.items()
            if limits.origin(field)}
    return {**_CONSTANT_COMMENTS, **said}


def _repeats(g: Guard, remember: bool) -> If:
    """Count the calls in a row the reading repeats the last one in range (models/safety.py::stuck_readings);
    `remember`: keep this reading as the last one here (a held temperature does it after its jump check)."""
    x, same, last = Ref(g.name), f"Same_{g.index}", f"LastIn_{g.index}"
    one_more = If(((BinOp("<", Ref(same), Ref("c_StuckCalls")), (Assign(same, BinOp("+", Ref(same), Ref("c_OneCall"))),)),))
    return If(((Ref(f"InOk_{g.index}"), (If(((BinOp("=", x, Ref(last)), (one_more,)),),
                                            orelse=(Assign(same, IntConst(0)),)),
                                         *((Assign(last, x),) if remember else ()))),))


def _guard_region(g: Guard, fault: str, stuck: bool) -> Region:
    x, ok = Ref(g.name), Ref(f"InOk_{g.index}")
    low, high = Ref(limit_name(g.low)), Ref(limit_name(g.high))
    in_range = Assign(ok.name, BinOp("AND", BinOp(">=", x, low), BinOp("<=", x, high)))
    last = f"LastIn_{g.index}"
    if g.kind == "fused":  # a stuck reading is no reading for the filter; LastIn_i is what the cross-sensor check reads
        repeats = (_repeats(g, remember=True),
                   Assign(ok.name, BinOp("AND", ok, BinOp("<", Ref(f"Same_{g.index}"), Ref("c_StuckCalls"))))
                   ) if stuck else (If(((ok, (Assign(last, x),)),)),)
        return Region(f"Input {g.index} {g.name}: range{' and stuck' if stuck else ''} check (the filter decides the "
                      f"fault)", (in_range, *repeats, If(((Unary("NOT", Ref(READY_OUTPUT)),
                                                           (Assign(fault, Unary("NOT", ok)),)),))))
    hold = If(((Unary("NOT", Ref(fault)), (Assign(f"Good_{g.index}", x),)),))
    if g.kind == "range":
        return Region(f"Input {g.index} {g.name}: range check, hold the last good value", (
            in_range, Assign(fault, Unary("NOT", ok)), hold))
    settle = f"Settle_{g.index}"
    reset = (Assign(fault, BoolConst(True)), Assign(settle, IntConst(0)))
    steady = BinOp("<=", Call("ABS", (BinOp("-", x, Ref(last)),)), Ref("c_JumpMax"))
    count = (Assign(settle, BinOp("+", Ref(settle), Ref("c_OneCall"))),
             If(((BinOp(">=", Ref(settle), Ref("c_SettleCalls")), (Assign(fault, BoolConst(False)), Assign(settle, IntConst(0)))),)))
    decide = If((
        (Unary("NOT", Ref(READY_OUTPUT)), (Assign(fault, Unary("NOT", ok)), Assign(settle, IntConst(0)))),
        (Unary("NOT", ok), reset),
        (Unary("NOT", steady), reset),
        *(((BinOp(">=", Ref(f"Same_{g.index}"), Ref("c_StuckCalls")), reset),) if stuck else ()),
        (Ref(fault), count),
    ))
    return Region(f"Input {g.index} {g.name}: range, jump{' and stuck' if stuck else ''} check, hold the last good "
                  f"value", (in_range, *((_repeats(g, remember=False),) if stuck else ()), decide, If(((ok, (Assign(last, x),)),)), hold))


def _limit(name: str, model_value: str) -> tuple:
    """Rate limit and clamp; a NaN or Inf model value holds the last output and raises Invalid (every
    comparison with NaN is FALSE, so the finite test must be the one that lets a value through)."""
    y = Ref(name)
    step = (
        Assign("Delta", BinOp("-", Ref(model_value), y)),
        If(((BinOp(">", Ref("Delta"), Ref("c_StepMax")), (Assign(name, BinOp("+", y, Ref("c_StepMax"))),
                                                          Assign(LIMITED_OUTPUT, BoolConst(True)))),
            (BinOp("<", Ref("Delta"), Ref("c_StepMin")), (Assign(name, BinOp("+", y, Ref("c_StepMin"))),
                                                          Assign(LIMITED_OUTPUT, BoolConst(True))))),
           orelse=(Assign(name, Ref(model_value)),)),
    )
    finite = BinOp("<=", Call("ABS", (Ref(model_value),)), Ref("c_RealMax"))
    return (
        If(((finite, step),), orelse=(Assign(INVALID_OUTPUT, BoolConst(True)),)),
        If(((BinOp(">", y, Ref("c_OutMax")), (Assign(name, Ref("c_OutMax")), Assign(CLAMPED_OUTPUT, BoolConst(True)))),
            (BinOp("<", y, Ref("c_OutMin")), (Assign(name, Ref("c_OutMin")), Assign(CLAMPED_OUTPUT, BoolConst(True)))))),
    )


_MODEL_VALUE = "model value of "


def model_values(block: Block) -> dict:
    """Limited output -> the temporary holding the model's value before the rate limit and clamp."""
    return {v.comment[len(_MODEL_VALUE):]: v.name for v in block.temps if v.comment.startswith(_MODEL_VALUE)}


def with_safety(core: Block, plan: tuple[Guard, ...], axis_outputs: list[str], limits: Limits,
                faults: dict[str, str], fusion: Fusion | None = None, start: KnownStart | None = None,
                check: Check | None = None) -> Block:
    """The block `core` computes, made safe: guarded inputs, a start gate and limited outputs;
    `faults` names each input's fault bit (contract/outputs.py), which a fused core declares itself;
    `fusion` moves the target by the probings' offset before it is limited (generator/probing.py);
    `start` moves the target to the drift at the runs' start first (generator/start.py); `check` sets
    SensorsDisagree, which holds the outputs as a fault bit does (generator/plausibility.py)."""
    limited = [v for v in core.outputs if v.type == "REAL"]
    model_names = {v.name: f"Model_{j}" for j, v in enumerate(limited, start=1)}
    held = {g.name: f"Good_{g.index}" for g in plan if g.kind != "fused"}
    body = rename(core.regions, {**model_names, **held})
    ready = reduce(lambda a, b: BinOp("AND", a, b), [Ref(f"InOk_{g.index}") for g in plan])
    # every model region runs only once the block is Ready; REGIONs stay at the top level (TIA)
    gated = lambda title, stmts: Region(title, (If(((Ref(READY_OUTPUT), tuple(stmts)),)),))
    fault_hold = hold_region([faults[g.name] for g in plan] + ([DISAGREE_OUTPUT] if check else []),
                             [model_names[v.name] for v in limited])
    regions = [
        *(_guard_region(g, faults[g.name], limits.stuck_calls is not None) for g in plan),
        Region("Start the model at the first call with every input in range", (
            If(((Unary("NOT", Ref(READY_OUTPUT)), (Assign(READY_OUTPUT, ready),)),)),)),
        *((check_region(check),) if check else ()),
        *(gated(r.title, r.body) for r in body),
        *(gated(r.title, r.body) for r in ([start_region(model_names[start.target])] if start else [])),
        gated(fault_hold.title, fault_hold.body),
        *(gated(r.title, r.body) for r in ([fusion_region(fusion, model_names[fusion.target])] if fusion else [])),
        Region("Output status: nothing limited yet in this call",
               (Assign(LIMITED_OUTPUT, BoolConst(False)), Assign(CLAMPED_OUTPUT, BoolConst(False)),
                Assign(INVALID_OUTPUT, BoolConst(False)))),
    ]
    k0 = {name: k0_output(k) for k, name in enumerate(axis_outputs, start=1)}
    for v in limited:
        stmts = _limit(v.name, model_names[v.name])
        if v.name in k0:
            stmts += (Assign(k0[v.name], BinOp("*", Ref(v.name), Ref("c_K0_mm"))),)
        title = f"Output {v.name}: rate limit, clamp" + (", K0 for SD43900 $SA_TEMP_COMP_ABS_VALUE" if v.name in k0 else "")
        regions.append(gated(title, stmts))
    core_flags = {v.name: v for v in core.outputs if v.type != "REAL"}
    fault_bits = []
    for g in plan:
        name = faults[g.name]
        fault_bits.append(core_flags.pop(name, None) or Var(name, "BOOL", f"{g.name} faulty: holding its last good value"))
    added = declarations(fusion) if fusion else {}
    checked = check_declarations(check) if check else {}
    outputs = (*limited,
               *(Var(k0[v.name], "REAL", f"K0 of {v.name} for SD43900, mm") for v in limited if v.name in k0),
               *core_flags.values(), *fault_bits, *checked.get("outputs", ()), *added.get("outputs", ()),
               Var(READY_OUTPUT, "BOOL", "TRUE once every input was in range: the model runs"),
               Var(LIMITED_OUTPUT, "BOOL", "an output was rate-limited in this call"),
               Var(CLAMPED_OUTPUT, "BOOL", "an output was clamped in this call"),
               Var(INVALID_OUTPUT, "BOOL", "the model gave NaN or Inf in this call: the last output is held"))
    if limits.fault_move is None:
        raise GenerationError("the safety limits have no fault hold (fault_move None: a block read back from before "
                              "it); give --fault-move-um")
    added_hold = hold_declarations(len(limited))
    statics = [*core.statics, *(START_STATICS if start else ()), *added.get("statics", ()), *added_hold["statics"],
               *checked.get("statics", ())]
    stuck = limits.stuck_calls is not None
    for g in plan:
        if g.kind in ("temperature", "fused"):
            statics.append(Var(f"LastIn_{g.index}", "REAL", f"{g.name}: last reading in range"))
        if g.kind == "temperature":
            statics.append(Var(f"Settle_{g.index}", "INT", f"{g.name}: steady calls while faulty"))
        if g.kind in ("temperature", "fused") and stuck:
            statics.append(Var(f"Same_{g.index}", "INT", f"{g.name}: calls in a row repeating the last reading"))
        if g.kind != "fused":
            statics.append(Var(f"Good_{g.index}", "REAL", f"{g.name}: last good value"))
    temps = (*core.temps, *(Var(f"InOk_{g.index}", "BOOL", f"{g.name} reads in range") for g in plan),
             *(Var(model_names[v.name], "REAL", f"{_MODEL_VALUE}{v.name}") for v in limited),
             Var("Delta", "REAL", "wanted output change"), *checked.get("temps", ()), *added.get("temps", ()),
             *added_hold["temps"])
    referenced = {e.name for e in walk_exprs(tuple(regions)) if isinstance(e, Ref)}
    comments = {**_limit_comments(limits), **PROBE_COMMENTS, **START_COMMENTS, **(check.comments if check else {})}
    constants = (*core.constants, *(Const(name, value, comments[name], "INT" if isinstance(value, int) else "REAL")
                                    for name, value in {**limit_constants(limits), **(fusion.constants if fusion else {}),
                                                                 **(start.constants if start else {}),
                                                                 **(check.constants if check else {})}
                                    .items() if name in referenced))
    return replace(core, inputs=(*core.inputs, *added.get("inputs", ())), outputs=outputs, statics=tuple(statics),
                   temps=temps, constants=constants, regions=tuple(regions))
