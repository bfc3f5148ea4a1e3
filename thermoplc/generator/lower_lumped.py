"""The lumped-mass simulation block: the identified baseline `fit` writes, or the effects `diagnose` found.

This module lowers the baseline (heat input, lag, the reading's correction KF_i, the structure lag,
the standstill load H_i and the sensor offset O_i wherever the model file has them); each named
effect's own statements come from its module in generator/lumped_effects/."""
from __future__ import annotations

from thermoplc.generator import lumped_effects
from thermoplc.generator.ir import Assign, BinOp, Block, Const, Ref, Region, Var
from thermoplc.generator.lower_shared import INIT, const, error_output, first_call, header, inputs_of, sum_of
from thermoplc.generator.lumped_effects import Lumped, State, lag
from thermoplc.models.kinds import lumped_model
from thermoplc.models.model import Model


def _sensor(block: Lumped, effects, i: int, name: str) -> tuple[State, Region]:
    """Sensor i's state and its region: heat input, lag step, the reading's correction, the structure."""
    c = block.model.coefficients
    start = BinOp("-", Ref(name), const(f"O_{i}")) if f"O_{i}" in c else Ref(name)
    init = [Assign(f"Tsim_{i}", start), Assign(f"T0_{i}", Ref(f"Tsim_{i}"))]
    statics = [Var(f"Tsim_{i}", "REAL", f"simulated temperature at {name}, degC"),
               Var(f"T0_{i}", "REAL", f"simulated temperature at {name} at the first call, degC")]
    if block.structure:
        init.append(Assign(f"L_{i}", Ref(f"Tsim_{i}")))
        statics.append(Var(f"L_{i}", "REAL", f"structure lagging {name}, degC"))
    heat = [Assign("Q", BinOp("*", const(f"G_{i}"), Ref("S")))]
    if f"H_{i}" in c:
        heat.append(Assign("Q", BinOp("+", Ref("Q"), const(f"H_{i}"))))
    drive = BinOp("+", Ref("Q"), block.ambient)
    step = lag(f"Tsim_{i}", f"A_{i}", f"B_{i}", drive)
    for effect in effects:
        added = effect.sensor_state(block, i)
        init += added.init
        statics += added.statics
        heat += effect.heat(block, i)
        step = effect.step(block, i, drive, step) if effect.step else step
    body = [*heat, step]
    if f"KF_{i}" in c:
        body.append(Assign(f"Tsim_{i}", BinOp("+", Ref(f"Tsim_{i}"), BinOp(
            "*", const(f"KF_{i}"), BinOp("-", Ref(name), Ref(f"Tsim_{i}"))))))
    if block.structure:
        body.append(lag(f"L_{i}", "AS", "BS", Ref(f"Tsim_{i}")))
    for effect in effects:
        body += effect.after_step(block, i)
    title = (f"Sensor {i} {name}: heat input and lumped-mass temperature, paper 000 eq. 4"
             + ("; corrected by the reading (steady-state Kalman filter)" if f"KF_{i}" in c else "")
             + ("; structure lag" if block.structure else ""))
    return State(tuple(init), tuple(statics)), Region(title, tuple(body))


def _displacement(block: Lumped, effects, sensors: int) -> Region:
    """E := beta0 + each sensor's terms + the shared ones, paper 000 eq. 10."""
    terms = [const("beta0")]
    for i in range(1, sensors + 1):
        terms.append(BinOp("*", const(f"beta_{i}"), BinOp("-", Ref(f"Tsim_{i}"), Ref(f"T0_{i}"))))
        if block.structure:
            terms.append(BinOp("*", const(f"gamma_{i}"), BinOp("-", Ref(f"L_{i}"), Ref(f"T0_{i}"))))
        for effect in effects:
            terms += effect.sensor_terms(block, i)
    for effect in effects:
        terms += effect.terms(block)
    return Region("Displacement from the simulated temperatures, paper 000 eq. 10",
                  (Assign(block.model.target.name, sum_of(terms)),))


def lower_lumped(model: Model) -> Block:
    """The block of a `lumped` model: first call, speed heat, each sensor, shared lags, displacement,
    then what the effects run after it, in the order models/kinds/lumped_model.py computes them."""
    temps = model.signals("temperature")
    block = Lumped(model, Ref(model.signals("speed")[0].name), Ref(model.signals("ambient")[0].name),
                   structure="AS" in model.coefficients)
    effects = lumped_effects.of_model(lumped_model.effect_names(model))
    # table coefficients are never constants: without their effect they are unused, and generate refuses them
    in_tables = tuple(f"{stem}_" for effect in lumped_effects.lowerings().values() for stem in effect.table_stems)
    constant_names = [name for name in model.coefficients if not name.startswith(in_tables)]
    comments = {**_BASELINE_COMMENTS, **{stem: text for record in lumped_effects.lowerings().values()
                                         for stem, text in record.comments}}
    constants = [Const(f"c_{name}", model.coef(name), comments.get(name.split("_")[0], "")) for name in constant_names]
    states, sensor_regions = zip(*(_sensor(block, effects, i, s.name) for i, s in enumerate(temps, start=1)))
    ambient_start = State((Assign("Te0", block.ambient),), (Var("Te0", "REAL", "ambient at the first call, degC"),))
    states = [*states, ambient_start, *(effect.shared_state(block) for effect in effects),
              *(effect.closing_state(block) for effect in effects)]
    shared = tuple(stmt for effect in effects for stmt in effect.shared(block))
    speed = next((effect.speed(block) for effect in effects if effect.speed), None)
    statics = [INIT, *(v for state in states for v in state.statics), *(speed.statics if speed else ())]
    regions = [first_call("First call: start the simulation at the measured temperatures",
                          [a for state in states for a in state.init]),
               speed.region if speed else Region("Speed heat input", (Assign("S", block.speed),))]
    heat_lags = tuple(stmt for effect in effects for stmt in effect.heat_lags(block))
    if heat_lags:
        regions.append(Region("Heat inputs that reach the sensors through a lag of their own", heat_lags))
    regions += sensor_regions
    if shared:
        regions.append(Region("Ambient coupling and feed-axis heat lags", shared))
    regions.append(_displacement(block, effects, len(temps)))
    regions += [region for effect in effects for region in effect.closing(block)]
    inputs = (*temps, *model.signals("speed"), *model.signals("ambient"), *model.signals("feed"))
    return Block(
        name=model.block_name,
        title="Thermal compensation: lumped-mass simulation (paper 000)",
        header=(*header(model), f"Effects: {', '.join(lumped_model.effect_names(model)) or 'none'}."),
        inputs=inputs_of(inputs),
        outputs=(error_output(model),),
        statics=tuple(statics),
        temps=(Var("S", "REAL", "speed heat input"), Var("Q", "REAL", "heat input of one sensor, K")),
        constants=(*constants, *(c for state in states for c in state.constants)),
        regions=tuple(regions),
    )


_BASELINE_COMMENTS = {
    "A": "decay per call while running", "B": "1 - A", "G": "steady rise per unit of speed heat, K",
    "H": "rise above the air at standstill (heat load), K", "O": "sensor offset, K",
    "KF": "share of the reading's disagreement taken each call (Kalman gain)",
    "AS": "structure decay per call", "BS": "1 - AS",
    "beta0": "intercept, um", "beta": "um per K of the simulated temperature", "gamma": "um per K of the structure lag",
}


LOWERINGS = {"lumped": lower_lumped}  # model kind -> its lowering, collected by generator/lower.py
