"""The Kalman fusion block of paper 000: per sensor a lumped-mass prediction, a fault test and an update."""
from __future__ import annotations

from thermoplc.base.binary32 import FLT_MIN_NORMAL
from thermoplc.contract.outputs import fault_outputs
from thermoplc.generator.ir import (
    Assign, BinOp, Block, BoolConst, Call, Const, GenerationError, If, Ref, Region, Unary, Var,
)
from thermoplc.models.kinds.kalman import SENSOR_COEFFICIENTS
from thermoplc.models.model import Model
from thermoplc.generator.lower_shared import (
    INIT, const, error_output, first_call, header, inputs_of, regression, regression_constants, sum_of,
)

_KALMAN_COMMENTS = {
    "A": "lumped-mass decay A = mc/dt / (mc/dt + v1), eq. 5",
    "AA": "A*A folded in binary32, eq. 6",
    "B": "ambient coupling B = v1 / (mc/dt + v1), eq. 5",
    "C": "speed heat per rpm C, eq. 3-5",
    "D": "standstill heat D",
    "N": "process noise covariance N, eq. 6",
    "R": "measurement noise covariance R, eq. 7",
    "P0": "covariance at the first call",
    "Jmp": "jump per call that marks the sensor faulty, K",
    "Agr": "|measured - predicted| below which a faulty sensor recovers, K",
}

def _check_noise(model: Model, sensors: int) -> None:
    """Zero or negative covariances make the gain 0/0 (NaN) or negative: refused before any text."""
    for i in range(1, sensors + 1):
        for name in ("N", "R", "P0"):
            value = model.coef(f"{name}_{i}")
            if not value >= FLT_MIN_NORMAL:
                raise GenerationError(f"coefficient {name}_{i} ({_KALMAN_COMMENTS[name]}) is {value:g}; the Kalman "
                                      f"filter needs it > 0 and normal (>= {FLT_MIN_NORMAL:.7g}): with zero noise its "
                                      f"gain is 0/0, and a PLC that flushes subnormals to zero makes it so")


def lower_kalman(model: Model) -> Block:
    temps = model.signals("temperature")
    _check_noise(model, len(temps))
    ambient = model.signals("ambient")[0].name
    speed = model.signals("speed")[0].name
    fault = fault_outputs(model)  # each sensor's fault bit, named as the safety logic names it
    init = []
    regions = []
    for i, s in enumerate(temps, start=1):
        measured = Ref(s.name)
        init += [Assign(f"T0_{i}", measured), Assign(f"TF_{i}", measured), Assign(f"PF_{i}", const(f"P0_{i}")),
                 Assign(f"TM_{i}", measured)]
        prediction = sum_of([BinOp("*", const(f"A_{i}"), Ref(f"TF_{i}")), BinOp("*", const(f"B_{i}"), Ref(ambient)),
                           BinOp("*", const(f"C_{i}"), Ref(speed)), const(f"D_{i}")])
        regions.append(Region(f"Sensor {i} {s.name}: lumped-mass prediction, eq. 4-6", (
            Assign("T_pred", prediction),
            Assign("P_pred", BinOp("+", BinOp("*", const(f"AA_{i}"), Ref(f"PF_{i}")), const(f"N_{i}"))),
        )))
        regions.append(Region(f"Sensor {i} {s.name}: fault criterion (out of range, sudden jump), paper 000 section 5", (
            If(((Unary("NOT", Ref(f"InOk_{i}")), (Assign(fault[s.name], BoolConst(True)),)),), orelse=(
                Assign("Jump", Call("ABS", (BinOp("-", measured, Ref(f"TM_{i}")),))),
                Assign(f"TM_{i}", measured),
                If(((Unary("NOT", BinOp("<=", Ref("Jump"), const(f"Jmp_{i}"))), (Assign(fault[s.name], BoolConst(True)),)),
                    (BinOp("<=", Call("ABS", (BinOp("-", measured, Ref("T_pred")),)), const(f"Agr_{i}")),
                     (Assign(fault[s.name], BoolConst(False)),)))),
            )),
        )))
        regions.append(Region(f"Sensor {i} {s.name}: Kalman update, eq. 7-9 (gain 0 while faulty)", (
            If(((Ref(fault[s.name]), (Assign(f"TF_{i}", Ref("T_pred")), Assign(f"PF_{i}", Ref("P_pred")))),),
               orelse=(
                   Assign("Gain", BinOp("/", Ref("P_pred"), BinOp("+", Ref("P_pred"), const(f"R_{i}")))),
                   Assign(f"TF_{i}", BinOp("+", Ref("T_pred"), BinOp("*", Ref("Gain"), BinOp("-", measured, Ref("T_pred"))))),
                   Assign(f"PF_{i}", BinOp("-", Ref("P_pred"), BinOp("*", Ref("Gain"), Ref("P_pred")))),
               )),
        )))
    statics = [INIT]
    constants = []
    for i, s in enumerate(temps, start=1):
        statics += [Var(f"T0_{i}", "REAL", f"{s.name} at the first call"),
                    Var(f"TF_{i}", "REAL", f"fused temperature of {s.name}"),
                    Var(f"PF_{i}", "REAL", f"fused covariance of {s.name}"),
                    Var(f"TM_{i}", "REAL", f"{s.name} at the previous call")]
        constants += [Const(f"c_{name}_{i}", model.coef(f"{name}_{i}"), f"{s.name}: {_KALMAN_COMMENTS[name]}")
                      for name in SENSOR_COEFFICIENTS]
    return Block(
        name=model.block_name,
        title="Thermal compensation: Kalman fusion, lumped mass (paper 000)",
        header=header(model),
        inputs=inputs_of((*temps, *model.signals("speed"), *model.signals("ambient"))),
        outputs=(error_output(model),)
        + tuple(Var(fault[s.name], "BOOL", f"{s.name} faulty: model-only prediction") for s in temps),
        statics=tuple(statics),
        temps=(Var("T_pred", "REAL", "predicted temperature"), Var("P_pred", "REAL", "predicted covariance"),
               Var("Gain", "REAL", "Kalman gain"), Var("Jump", "REAL", "change of the measurement since the last call")),
        constants=tuple(constants + regression_constants(model)),
        regions=(first_call("First call: start the filters at the measured temperatures", init),
                 *regions,
                 regression(model, lambda i, s: Ref(f"TF_{i}"))),
    )


LOWERINGS = {"kalman": lower_kalman}  # model kind -> its lowering, collected by generator/lower.py
