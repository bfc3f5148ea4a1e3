"""The lumped-mass simulation block: the identified baseline `fit` writes, or the effects `diagnose` found."""
from __future__ import annotations

from thermoplc.generator.ir import Assign, BinOp, Block, BoolConst, Const, If, Index, IntConst, Ref, Region, Var
from thermoplc.models import lumped_model
from thermoplc.models.modelfile import Model
from thermoplc.generator.lower_shared import INIT, const, error_output, first_call, header, inputs_of, sum_of


def _lag(state: str, decay: str, drive: str, source) -> Assign:
    return Assign(state, BinOp("+", BinOp("*", const(decay), Ref(state)), BinOp("*", const(drive), source)))


def _speed_heat(model: Model, speed: Ref) -> tuple[tuple, list[Var]]:
    """S := n, or the n^p table interpolated at n (segment chosen by comparisons only)."""
    count = lumped_model.segments(model)
    if not count:
        return (Assign("S", speed),), []
    chain = tuple((BinOp(">=", speed, Index("tab_Node", IntConst(m))), (Assign("Ix", IntConst(m)),))
                  for m in range(count - 1, 0, -1))
    interpolate = Assign("S", BinOp("+", Index("tab_Heat", Ref("Ix")),
                                    BinOp("*", BinOp("-", speed, Index("tab_Node", Ref("Ix"))),
                                          Index("tab_Slope", Ref("Ix")))))
    tables = [Var(f"tab_{stem.capitalize()}", "REAL", f"{comment} (table, read only)", length=count,
                  initial=tuple(model.coef(f"{stem}_{m}") for m in range(1, count + 1)))
              for stem, comment in (("node", "speed table nodes, rpm"), ("heat", "speed heat n^p at the nodes"),
                                    ("slope", "speed heat slope per rpm"))]
    body = (If(chain, orelse=(Assign("Ix", IntConst(0)),)),) if count > 1 else (Assign("Ix", IntConst(0)),)
    return (*body, interpolate), tables


def lower_lumped(model: Model) -> Block:
    temps = model.signals("temperature")
    ambient = Ref(model.signals("ambient")[0].name)
    speed = Ref(model.signals("speed")[0].name)
    has = lambda name: lumped_model.has(model, name)
    constant_names = [name for name in model.coefficients if not name.startswith(("node_", "heat_", "slope_"))]
    constants = [Const(f"c_{name}", model.coef(name), _LUMPED_COMMENTS.get(name.split("_")[0], "")) for name in constant_names]
    statics = [INIT]
    init = []
    sensor_regions = []
    structure = "AS" in model.coefficients
    for i, s in enumerate(temps, start=1):
        start = BinOp("-", Ref(s.name), const(f"O_{i}")) if f"O_{i}" in model.coefficients else Ref(s.name)
        init += [Assign(f"Tsim_{i}", start), Assign(f"T0_{i}", Ref(f"Tsim_{i}"))]
        statics += [Var(f"Tsim_{i}", "REAL", f"simulated temperature at {s.name}, degC"),
                    Var(f"T0_{i}", "REAL", f"simulated temperature at {s.name} at the first call, degC")]
        if structure:
            init.append(Assign(f"L_{i}", Ref(f"Tsim_{i}")))
            statics.append(Var(f"L_{i}", "REAL", f"structure lagging {s.name}, degC"))
        if has("slow_structure"):
            init.append(Assign(f"M_{i}", Ref(f"Tsim_{i}")))
            statics.append(Var(f"M_{i}", "REAL", f"slow structure lagging {s.name}, degC"))
        heat = [Assign("Q", BinOp("*", const(f"G_{i}"), Ref("S")))]
        if f"H_{i}" in model.coefficients:
            heat.append(Assign("Q", BinOp("+", Ref("Q"), const(f"H_{i}"))))
        if has("gear_ratio_switch"):
            heat.append(If(((BinOp(">", speed, const("Gear_rpm")),
                             (Assign("Q", BinOp("+", Ref("Q"), BinOp("*", const(f"G2_{i}"), speed))),)),)))
        if has("coolant_switching"):
            heat.append(If(((Ref("Cool"), (Assign("Q", BinOp("+", Ref("Q"), const(f"K_{i}"))),)),)))
        drive = BinOp("+", Ref("Q"), ambient)
        step = _lag(f"Tsim_{i}", f"A_{i}", f"B_{i}", drive)
        if has("stop_convection"):
            step = If(((BinOp("<=", speed, const("Stop_rpm")), (_lag(f"Tsim_{i}", f"As_{i}", f"Bs_{i}", drive),)),),
                      orelse=(step,))
        body = [*heat, step]
        if f"KF_{i}" in model.coefficients:
            body.append(Assign(f"Tsim_{i}", BinOp("+", Ref(f"Tsim_{i}"), BinOp(
                "*", const(f"KF_{i}"), BinOp("-", Ref(s.name), Ref(f"Tsim_{i}"))))))
        if structure:
            body.append(_lag(f"L_{i}", "AS", "BS", Ref(f"Tsim_{i}")))
        if has("slow_structure"):
            body.append(_lag(f"M_{i}", "A2", "B2", Ref(f"L_{i}" if structure else f"Tsim_{i}")))
        sensor_regions.append(Region(f"Sensor {i} {s.name}: heat input and lumped-mass temperature, paper 000 eq. 4"
                                     + ("; corrected by the reading (steady-state Kalman filter)"
                                        if f"KF_{i}" in model.coefficients else "")
                                     + ("; structure lag" if structure else ""), tuple(body)))
    init += [Assign("Te0", ambient)]
    statics.append(Var("Te0", "REAL", "ambient at the first call, degC"))
    shared = []
    if has("ambient_coupling"):
        init.append(Assign("LA", ambient))
        statics.append(Var("LA", "REAL", "structure following the ambient, degC"))
        shared.append(_lag("LA", "AAm", "BAm", ambient))
    if has("feed_axis_heat"):
        feed = Ref(model.signals("feed")[0].name)
        init.append(Assign("LF", const("Zero")))
        constants.append(Const("c_Zero", 0.0, "feed heat at the first call"))
        statics.append(Var("LF", "REAL", "feed-axis heat, lagged"))
        shared.append(_lag("LF", "AF", "BF", feed))
    if has("coolant_switching"):
        init.append(Assign("Cool", BoolConst(False)))
        statics.append(Var("Cool", "BOOL", "coolant relay state"))
    terms = [const("beta0")]
    for i in range(1, len(temps) + 1):
        terms.append(BinOp("*", const(f"beta_{i}"), BinOp("-", Ref(f"Tsim_{i}"), Ref(f"T0_{i}"))))
        if structure:
            terms.append(BinOp("*", const(f"gamma_{i}"), BinOp("-", Ref(f"L_{i}"), Ref(f"T0_{i}"))))
        if has("slow_structure"):
            terms.append(BinOp("*", const(f"delta_{i}"), BinOp("-", Ref(f"M_{i}"), Ref(f"T0_{i}"))))
    if has("ambient_coupling"):
        terms.append(BinOp("*", const("alpha"), BinOp("-", Ref("LA"), Ref("Te0"))))
    if has("feed_axis_heat"):
        terms.append(BinOp("*", const("phi"), Ref("LF")))
    speed_body, tables = _speed_heat(model, speed)
    if tables:
        statics += [Var("Ix", "INT", "speed table segment"), *tables]
    regions = [first_call("First call: start the simulation at the measured temperatures", init),
               Region("Speed heat input" + (" n^p from the table (nonlinear_speed_heat)" if tables else ""), speed_body),
               *sensor_regions]
    if shared:
        regions.append(Region("Ambient coupling and feed-axis heat lags", tuple(shared)))
    regions.append(Region("Displacement from the simulated temperatures, paper 000 eq. 10", (Assign(model.target.name, sum_of(terms)),)))
    if has("coolant_switching"):
        switch = Ref(f"Tsim_{model.settings.get('relay_sensor', 1)}")
        regions.append(Region("Coolant relay with hysteresis on the simulated temperature (coolant_switching), used from the next call", (
            If(((BinOp(">", switch, const("CoolOn")), (Assign("Cool", BoolConst(True)),)),
                (BinOp("<", switch, const("CoolOff")), (Assign("Cool", BoolConst(False)),)))),)))
    inputs = (*temps, *model.signals("speed"), *model.signals("ambient"), *model.signals("feed"))
    effects = ", ".join(lumped_model.effect_names(model)) or "none"
    return Block(
        name=model.block_name,
        title="Thermal compensation: lumped-mass simulation (paper 000)",
        header=(*header(model), f"Effects: {effects}."),
        inputs=inputs_of(inputs),
        outputs=(error_output(model),),
        statics=tuple(statics),
        temps=(Var("S", "REAL", "speed heat input"), Var("Q", "REAL", "heat input of one sensor, K")),
        constants=tuple(constants),
        regions=tuple(regions),
    )


_LUMPED_COMMENTS = {
    "A": "decay per call while running", "B": "1 - A", "As": "decay per call at standstill (stop_convection)",
    "Bs": "1 - As", "G": "steady rise per unit of speed heat, K", "G2": "extra rise per rpm above the gear threshold, K",
    "K": "rise while the coolant runs, K", "H": "rise above the air at standstill (heat load), K",
    "O": "sensor offset, K", "KF": "share of the reading's disagreement taken each call (Kalman gain)", "Stop": "standstill at or below, rpm",
    "Gear": "gear threshold, rpm", "CoolOn": "coolant on above, degC", "CoolOff": "coolant off below, degC",
    "AS": "structure decay per call", "BS": "1 - AS", "A2": "slow structure decay per call", "B2": "1 - A2",
    "AAm": "ambient coupling decay per call", "BAm": "1 - AAm", "AF": "feed heat decay per call", "BF": "1 - AF",
    "beta0": "intercept, um", "beta": "um per K of the simulated temperature", "gamma": "um per K of the structure lag",
    "delta": "um per K of the slow structure", "alpha": "um per K of the lagged ambient",
    "phi": "um per mm/min of lagged feed",
}


LOWERINGS = {"lumped": lower_lumped}  # model kind -> its lowering, collected by generator/lower.py
