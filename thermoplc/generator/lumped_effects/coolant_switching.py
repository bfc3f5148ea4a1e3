"""coolant_switching in the block: while the relay is on each sensor's heat input gains K_i, at once or, when the
model file has the cooling's lag (ACl/BCl), through LC, the relay state lagged from 0; the relay switches on the
simulated temperature of its sensor with hysteresis, used from the next call."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, BoolConst, If, Ref, Region, Var
from thermoplc.generator.lower_shared import const
from thermoplc.generator.lumped_effects.lowering import EffectLowering, Lumped, State, lag_state
from thermoplc.models.kinds import lumped_model

FLOOR = "c_Cool_Floor"  # contract/constants.structure_name of the lumped kind's `cool_floor`


def _lagged(block: Lumped) -> bool:
    return "ACl" in block.model.coefficients


def cooling_lag(block: Lumped) -> State:
    if not _lagged(block):
        return State()
    return lag_state("LC", "share of the coolant's cooling reaching the sensors, lagged, 0..1", FLOOR,
                     lumped_model.COOL_FLOOR, "a lagged coolant share below this is 0 (before a long time off makes it "
                                              "subnormal)")


def heat_lags(block: Lumped) -> tuple:
    if not _lagged(block):
        return ()
    kept = BinOp("*", const("ACl"), Ref("LC"))
    return (If(((Ref("Cool"), (Assign("LC", BinOp("+", kept, const("BCl"))),)),), (Assign("LC", kept),)),
            If(((BinOp("<", Ref("LC"), Ref(FLOOR)), (Assign("LC", const("Zero")),)),)))


def heat(block: Lumped, i: int) -> tuple:
    if _lagged(block):
        return (Assign("Q", BinOp("+", Ref("Q"), BinOp("*", const(f"K_{i}"), Ref("LC")))),)
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
    ("ACl", "decay per call of the coolant's cooling"),
    ("BCl", "1 - ACl"),
)

LOWERING = EffectLowering("coolant_switching", comments=COMMENTS, shared_state=cooling_lag, heat_lags=heat_lags,
                          heat=heat, closing_state=relay_state, closing=relay)
