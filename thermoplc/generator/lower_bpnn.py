"""The GA-BP neural network block of paper 002, with the Pade tanh and tool-tip compensation."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, Block, Const, If, Ref, Region, Var
from thermoplc.models.kinds.bpnn import has_compensation, output_names
from thermoplc.models.model import Model
from thermoplc.generator.lower_shared import (
    INIT, const, first_call, header, inputs_of, reference_vars, references, sum_of, weighted_rises,
)


def _horner(z2, names: tuple[str, ...]):
    """a0 + z2*(a1 + z2*(a2 + z2*a3)) over named constants."""
    expr = const(names[-1])
    for name in reversed(names[:-1]):
        expr = BinOp("+", const(name), BinOp("*", z2, expr))
    return expr


def lower_bpnn(model: Model) -> Block:
    temps = model.signals("temperature")
    m, hidden, q = model.settings["inputs"], model.settings["hidden"], model.settings["outputs"]
    names = output_names(model)
    units = [t["unit"] for t in model.settings["targets"]]
    skip = model.settings.get("skip") == "ridge"
    scaled = tuple(Assign(f"X_{i}", BinOp("+", BinOp("*", BinOp("-", Ref(s.name), Ref(f"T0_{i}")), const(f"in_scale_{i}")),
                                          const(f"in_shift_{i}"))) for i, s in enumerate(temps, start=1))
    layer = []
    for j in range(1, hidden + 1):
        layer += [
            Assign("Z", sum_of([const(f"b1_{j}")] + [BinOp("*", const(f"w1_{j}_{i}"), Ref(f"X_{i}")) for i in range(1, m + 1)])),
            If(((BinOp("<", Ref("Z"), const("act_nclip")), (Assign("Z", const("act_nclip")),)),
                (BinOp(">", Ref("Z"), const("act_clip")), (Assign("Z", const("act_clip")),)))),
            Assign("Zsq", BinOp("*", Ref("Z"), Ref("Z"))),
            Assign(f"H_{j}", BinOp("/", BinOp("*", Ref("Z"), _horner(Ref("Zsq"), ("act_one", "act_p1", "act_p2", "act_p3"))),
                                   _horner(Ref("Zsq"), ("act_one", "act_q1", "act_q2", "act_q3"))))]
    outputs = []
    for k in range(1, q + 1):
        y = sum_of([const(f"b2_{k}")] + [BinOp("*", const(f"w2_{k}_{j}"), Ref(f"H_{j}")) for j in range(1, hidden + 1)])
        scaled_back = BinOp("+", BinOp("*", Ref("Y"), const(f"out_scale_{k}")), const(f"out_shift_{k}"))
        outputs += [Assign("Y", y)] + ([Assign("Ridge", weighted_rises(f"ridge{k}_0", f"ridge{k}", temps)),
                                         Assign(names[k - 1], BinOp("+", Ref("Ridge"), scaled_back))]
                                        if skip else [Assign(names[k - 1], scaled_back)])
    regions = [first_call("First call: latch reference temperatures", references(temps)),
               Region("Input layer: temperature rises scaled to [-1, 1]", scaled),
               Region("Hidden layer: act(x) = Pade(7,6) tanh of clip(x, +-4.97)", tuple(layer)),
               Region("Output layer, scaled back to units" + (", plus the ridge on every rise" if skip else ""),
                      tuple(outputs))]
    out_vars = [Var(n, "REAL", f"predicted {n}, {u}") for n, u in zip(names, units)]
    inputs = list(inputs_of(temps))
    if has_compensation(model):
        length = model.signals("tool_length")[0].name
        inputs.append(Var(length, "REAL", "tool length, mm"))
        regions.append(Region("Compensation per axis, paper 002: Dx = L*yaw, Dy = L*pitch, Dz = elongation", (
            Assign("Dx_um", BinOp("*", BinOp("*", Ref(length), Ref(names[1])), const("um_per_mm_urad"))),
            Assign("Dy_um", BinOp("*", BinOp("*", Ref(length), Ref(names[2])), const("um_per_mm_urad"))),
            Assign("Dz_um", Ref(names[0])))))
        out_vars += [Var(n, "REAL", f"thermal error along {n[1]} at the tool tip, um") for n in ("Dx_um", "Dy_um", "Dz_um")]
    return Block(
        name=model.block_name,
        title=f"Thermal compensation: GA-BP neural network {m}-{hidden}-{q} (paper 002)",
        header=header(model),
        inputs=tuple(inputs),
        outputs=tuple(out_vars),
        statics=(INIT, *reference_vars(temps)),
        temps=(*(Var(f"X_{i}", "REAL", f"scaled rise of {s.name}") for i, s in enumerate(temps, start=1)),
               *(Var(f"H_{j}", "REAL", f"hidden neuron {j}") for j in range(1, hidden + 1)),
               Var("Z", "REAL", "neuron input"), Var("Zsq", "REAL", "neuron input squared"),
               Var("Y", "REAL", "scaled output"),
               *((Var("Ridge", "REAL", "the ridge on every rise, um"),) if skip else ())),
        constants=tuple(Const(f"c_{name}", model.coef(name), "") for name in model.coefficients),
        regions=tuple(regions),
    )


LOWERINGS = {"bpnn": lower_bpnn}  # model kind -> its lowering, collected by generator/lower.py
