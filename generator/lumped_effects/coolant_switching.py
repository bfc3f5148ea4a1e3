"""coolant_switching in the block: while the relay is on each sensor's heat input gains K_i; the relay
switches on the simulated temperature of its sensor with hysteresis, used from the next call."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, BoolConst, If, Ref, Region, Var
from thermoplc.generator.lower_shared import const
from thermoplc.generator.lumped_effects.lowering import EffectLowering, Lumped, State


def heat(block: Lumped, i: int) -> tuple:
    return (If(((Ref("Cool"), (Assign("Q", BinOp("+", Ref("Q"), const(f"K_{i}"))),)),)),)


def relay_state(block: Lumped) -> State:
    return State(init=(Assign("Cool", BoolConst(False)),), statics=(Var("Cool", "BOOL", "coolant relay state"),))


def relay(block: Lumped) -> tuple:
    switch = Ref(f"Tsim_{block.model.settings.get('relay_sensor', 1)}")
    return (Region("Coolant relay with hysteresis on the simulated temperature (coolant_switching), used from the "
                   "next call", (If(((BinOp(">", switch, const("CoolOn")), (Assign("Cool", BoolConst(True)),)),
                                     (BinOp("<", switch, const("CoolOff")), (Assign("Cool", BoolConst(False)),)))),)),)


COMMENTS = (
    ("K", "rise while the coolant runs, K"),
    ("CoolOn", "coolant on above, degC"),
    ("CoolOff", "coolant off below, degC"),
)

LOWERING = EffectLowering("coolant_switching", comments=COMMENTS, heat=heat, closing_state=relay_state, closing=relay)
