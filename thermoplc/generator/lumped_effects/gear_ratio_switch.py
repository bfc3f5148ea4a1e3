"""gear_ratio_switch in the block: above c_Gear_rpm each sensor's heat input gains G2_i * n, at once or, when the
model file has its lag (AGr/BGr), through LG, the speed above the threshold lagged from 0."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, Call, If, Ref
from thermoplc.generator.lower_shared import const
from thermoplc.generator.lumped_effects.lowering import EffectLowering, Lumped, State, lag_state
from thermoplc.models.kinds import lumped_model

FLOOR = "c_Gear_Floor"  # contract/constants.structure_name of the lumped kind's `gear_floor`


def _lagged(block: Lumped) -> bool:
    return "AGr" in block.model.coefficients


def state(block: Lumped) -> State:
    if not _lagged(block):
        return State()
    return lag_state("LG", "speed above the gear threshold, lagged, rpm", FLOOR, lumped_model.GEAR_FLOOR_RPM,
                     "a lagged gear speed below this is 0 (before a long stop makes it subnormal), rpm")


def heat_lags(block: Lumped) -> tuple:
    if not _lagged(block):
        return ()
    kept = BinOp("*", const("AGr"), Ref("LG"))
    return (If(((BinOp(">", block.speed, const("Gear_rpm")),
                 (Assign("LG", BinOp("+", kept, BinOp("*", const("BGr"), block.speed))),)),),
               (Assign("LG", kept),)),
            If(((BinOp("<", Call("ABS", (Ref("LG"),)), Ref(FLOOR)), (Assign("LG", const("Zero")),)),)))


def heat(block: Lumped, i: int) -> tuple:
    if _lagged(block):
        return (Assign("Q", BinOp("+", Ref("Q"), BinOp("*", const(f"G2_{i}"), Ref("LG")))),)
    return (If(((BinOp(">", block.speed, const("Gear_rpm")),
                 (Assign("Q", BinOp("+", Ref("Q"), BinOp("*", const(f"G2_{i}"), block.speed))),)),)),)


COMMENTS = (
    ("G2", "extra rise per rpm above the gear threshold, K"),
    ("Gear", "gear threshold, rpm"),
    ("AGr", "decay per call of the heat above the gear threshold"),
    ("BGr", "1 - AGr"),
)

LOWERING = EffectLowering("gear_ratio_switch", comments=COMMENTS, shared_state=state, heat_lags=heat_lags, heat=heat)
