"""slow_structure in the block: M_i lags the structure (or the simulated temperature) with the slow
pole A2/B2, and delta_i weighs its rise."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, Ref, Var
from thermoplc.generator.lower_shared import const
from thermoplc.generator.lumped_effects.lowering import EffectLowering, Lumped, State, lag


def state(block: Lumped, i: int) -> State:
    name = block.model.signals("temperature")[i - 1].name
    return State(init=(Assign(f"M_{i}", Ref(f"Tsim_{i}")),),
                 statics=(Var(f"M_{i}", "REAL", f"slow structure lagging {name}, degC"),))


def step(block: Lumped, i: int) -> tuple:
    return (lag(f"M_{i}", "A2", "B2", Ref(f"L_{i}" if block.structure else f"Tsim_{i}")),)


def term(block: Lumped, i: int) -> tuple:
    return (BinOp("*", const(f"delta_{i}"), BinOp("-", Ref(f"M_{i}"), Ref(f"T0_{i}"))),)


COMMENTS = (
    ("A2", "slow structure decay per call"),
    ("B2", "1 - A2"),
    ("delta", "um per K of the slow structure"),
)

LOWERING = EffectLowering("slow_structure", comments=COMMENTS, sensor_state=state, after_step=step, sensor_terms=term)
