"""The `lumped` model kind: paper 000's lumped-mass simulation with named effects, as a block.

The block simulates the temperatures from speed, ambient (and feed); the measured temperatures
set the start and, in a model identified by `fit` (physics/identify.py), correct the simulation
each call by a fixed share KF_i (the steady-state Kalman filter); a model `diagnose` fitted runs
open loop. Per call, in this order:
    S := n, or the n^p table interpolated at n                          (nonlinear_speed_heat)
    [LG := AGr*LG + BGr*n if n > Gear, else AGr*LG; 0 when |LG| < Gear_Floor]  (gear heat with a lag of its own)
    [LC := ACl*LC + BCl if Cool, else ACl*LC; 0 when LC < Cool_Floor]  (the coolant's cooling with a lag of its own)
    per sensor i:  Q := G_i*S [+ H_i] [+ G2_i*n if n > Gear, or + G2_i*LG] [+ K_i if Cool, or + K_i*LC]
                   Tsim_i := A_i*Tsim_i + B_i*(Q + Te)   (As_i, Bs_i while n <= Stop: stop_convection)
                   [Tsim_i := Tsim_i + KF_i*(T_i - Tsim_i)]  (filtered)
                   [L_i := AS*L_i + BS*Tsim_i]  [M_i := A2*M_i + B2*(L_i or Tsim_i)]  (structure, slow_structure)
    [LA := AAm*LA + BAm*Te]  [LF := AF*LF + BF*feed]
    E := beta0 + sum_i beta_i*(Tsim_i-T0_i) [+ gamma_i*(L_i-T0_i)] [+ delta_i*(M_i-T0_i)] [+ alpha*(LA-Te0)] [+ phi*LF]
    [relay: Cool := TRUE above CoolOn, FALSE below CoolOff, from the simulated temperature of the switching sensor]
First call: Tsim_i = L_i = M_i = T0_i := T_i [- O_i], LA = Te0 := Te, LF := 0, LG := 0, LC := 0, Cool := FALSE.
H_i is the standstill heat load (K above the air with the spindle still); model files written
before it existed have none and their blocks compute without it.
The displacement follows the simulated temperatures with their ambient-driven part (paper 000
eq. 10); the structure lag is absent when the model was fitted without one.
"""
from __future__ import annotations

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.base import ridge
from thermoplc.physics import primitives
from thermoplc.physics import identify, simulation as sim_
from thermoplc.models import decays
from thermoplc.models.kind import Kind
from thermoplc.models.lumped_kernel import COOL_FLOOR, GEAR_FLOOR_RPM, Flags, LumpedState, lumped_loop
from thermoplc.models.model import Coefficient, Model
from thermoplc.physics.fitted import Simulation


def effect_names(model: Model) -> tuple[str, ...]:
    return tuple(e["name"] for e in model.settings.get("effects", ()))


def has(model: Model, name: str) -> bool:
    return name in effect_names(model)


EFFECT_LAGS = ((("AGr", "BGr"), "gear_ratio_switch", "gear heat's"), (("ACl", "BCl"), "coolant_switching", "cooling's"))


def segments(model: Model) -> int:
    """The speed table's segments: the n^p heat of nonlinear_speed_heat (check_settings refuses a file
    with a table and without the effect, or the other way round)."""
    return int(model.settings.get("speed_table_segments", 0)) if has(model, "nonlinear_speed_heat") else 0


def _pair(a: float) -> tuple[Coefficient, Coefficient]:
    """A decay and its complement, each rounded once from float64 (B is not 1 - A in binary32)."""
    return Coefficient.of(a), Coefficient.of(1.0 - a)


def coefficients(sim: Simulation, dt: float) -> tuple[dict[str, Coefficient], dict]:
    """Model-file coefficients (block order) and settings of a fitted simulation."""
    c: dict[str, Coefficient] = {}
    filtered = any(p.filter_gain for p in sim.sensors)  # every sensor carries a gain or none: one flag in the block
    for i, p in enumerate(sim.sensors, start=1):
        c[f"A_{i}"], c[f"B_{i}"] = _pair(sim_.pole(p.tau_s, dt))
        if sim.has("stop_convection"):
            c[f"As_{i}"], c[f"Bs_{i}"] = _pair(sim_.pole(p.tau_s * p.stop_factor, dt))
        c[f"G_{i}"] = Coefficient.of(p.gain)
        c[f"H_{i}"] = Coefficient.of(p.load_K)
        if filtered:
            c[f"KF_{i}"] = Coefficient.of(p.filter_gain)
        if sim.has("gear_ratio_switch"):
            c[f"G2_{i}"] = Coefficient.of(p.gear_gain)
        if sim.has("coolant_switching"):
            c[f"K_{i}"] = Coefficient.of(p.cooling)
        if sim.has("sensor_offset") and sim.sensor_of("sensor_offset") == i - 1:
            c[f"O_{i}"] = Coefficient.of(p.offset_K)
    s = sim.shared
    if sim.has("stop_convection"):
        c["Stop_rpm"] = Coefficient.of(s.stopped_rpm)
    if sim.has("gear_ratio_switch"):
        c["Gear_rpm"] = Coefficient.of(s.gear_rpm)
        if s.gear_tau_s > 0:
            c["AGr"], c["BGr"] = _pair(sim_.pole(s.gear_tau_s, dt))
    if sim.has("coolant_switching"):
        c["CoolOn"], c["CoolOff"] = Coefficient.of(s.relay[1]), Coefficient.of(s.relay[2])
        if s.cool_tau_s > 0:
            c["ACl"], c["BCl"] = _pair(sim_.pole(s.cool_tau_s, dt))
    if sim.has("nonlinear_speed_heat"):
        nodes, values, slopes = primitives.speed_table(s)
        for m, (x, y, k) in enumerate(zip(nodes, values, slopes), start=1):
            c[f"node_{m}"], c[f"heat_{m}"], c[f"slope_{m}"] = Coefficient.of(x), Coefficient.of(y), Coefficient.of(k)
    d = sim.displacement
    terms = sim_.displacement_terms(sim.effects)
    if d.tau_struct_s is not None:
        c["AS"], c["BS"] = _pair(sim_.pole(d.tau_struct_s, dt))
    for term in terms:  # each displacement effect's lag, then its weights (per sensor beside beta_i, or one)
        c[term.pole[0]], c[term.pole[1]] = _pair(sim_.pole(getattr(d, term.tau_field), dt))
    c["beta0"] = Coefficient.of(d.beta0)
    for i in range(1, len(sim.sensors) + 1):
        c[f"beta_{i}"] = Coefficient.of(d.beta[i - 1])
        if d.tau_struct_s is not None:
            c[f"gamma_{i}"] = Coefficient.of(d.gamma[i - 1])
        for term in terms:
            if term.per_sensor:
                c[f"{term.weight}_{i}"] = Coefficient.of(term.weights(d)[i - 1])
    for term in terms:
        if not term.per_sensor:
            c[term.weight] = Coefficient.of(term.weights(d)[0])
    settings = {
        "effects": [{"name": name, "sensor": None if sensor is None else sensor + 1} for name, sensor in sim.effects],
        "sensors": [{"tau_s": p.tau_s, "stop_factor": p.stop_factor, "drift_K_per_h": p.drift_K_per_s * 3600}
                    for p in sim.sensors],
        "stopped_rpm": s.stopped_rpm,
        "tau_struct_s": d.tau_struct_s,
    }
    if sim.has("coolant_switching"):
        settings["relay_sensor"] = s.relay[0] + 1
    if sim.has("nonlinear_speed_heat"):
        settings["speed_table_segments"] = len(primitives.speed_table(s)[0])
        settings.update(exponent=s.exponent, reference_rpm=s.reference_rpm, table_rpm=list(s.table_rpm))
    return c, settings


def simulation_of(model: Model) -> Simulation:
    """The float64 simulation a `lumped` model file describes (a baseline for the diagnosis)."""
    dt = model.sample_period_s
    c = lambda name, default=0.0: model.coef(name, "f64") if name in model.coefficients else default
    tau = lambda a: -dt / np.log(a)
    st = model.settings
    effects = tuple((e["name"], None if e.get("sensor") is None else e["sensor"] - 1) for e in st.get("effects", ()))
    k = len(model.signals("temperature"))
    drift = [s.get("drift_K_per_h", 0.0) / 3600 for s in st.get("sensors", [{}] * k)]
    sensors = tuple(sim_.SensorParams(
        tau_s=tau(c(f"A_{i}")), gain=c(f"G_{i}"), load_K=c(f"H_{i}"),
        stop_factor=tau(c(f"As_{i}")) / tau(c(f"A_{i}")) if f"As_{i}" in model.coefficients else 1.0,
        gear_gain=c(f"G2_{i}"), cooling=c(f"K_{i}"), offset_K=c(f"O_{i}"), drift_K_per_s=drift[i - 1],
        filter_gain=c(f"KF_{i}"))
        for i in range(1, k + 1))
    shared = sim_.Shared(
        stopped_rpm=float(st.get("stopped_rpm", 0.0)), gear_rpm=c("Gear_rpm", None),
        gear_tau_s=tau(c("AGr")) if "AGr" in model.coefficients else 0.0,
        cool_tau_s=tau(c("ACl")) if "ACl" in model.coefficients else 0.0,
        exponent=st.get("exponent"), reference_rpm=float(st.get("reference_rpm", 1.0)),
        table_rpm=tuple(st.get("table_rpm", ())),
        relay=(st["relay_sensor"] - 1, c("CoolOn"), c("CoolOff")) if "relay_sensor" in st else None)
    structure = "AS" in model.coefficients
    fitted = {}
    for term in sim_.displacement_terms():  # each displacement effect's lag and weights, where the file has them
        if term.pole[0] in model.coefficients:
            fitted[term.tau_field] = tau(c(term.pole[0]))
            fitted[term.weight_field] = tuple(c(f"{term.weight}_{i}") for i in range(1, k + 1)) if term.per_sensor \
                else c(term.weight)
    displacement = primitives.DisplacementParams(
        tau_struct_s=tau(c("AS")) if structure else None, beta0=c("beta0"),
        beta=tuple(c(f"beta_{i}") for i in range(1, k + 1)),
        gamma=tuple(c(f"gamma_{i}") for i in range(1, k + 1)) if structure else (), **fitted,
        ridge_weight=_ridge_weight(model), tau_struct_chosen_s=_chosen_lag(model))
    return Simulation(effects, shared, sensors, displacement)


def _number(model: Model, key: str) -> float | None:
    value = (model.fit or {}).get(key)
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None


def _ridge_weight(model: Model) -> float | None:
    """The map's ridge weight of an identified model (its fit log says, `fit --model lumped` and diagnose write
    it; a model with filter gains and none is identified too); None for an open-loop simulation an earlier
    diagnose fitted by least squares. check_fit_log refuses a weight that is no number >= 0."""
    weight = _number(model, "ridge_weight")
    if weight is None and any(name.startswith("KF_") for name in model.coefficients):
        return 0.0
    return weight


def _chosen_lag(model: Model) -> float | None:
    """The structure lag forward validation chose, where a diagnose's fit log keeps it."""
    return _number(model, "structure_lag_chosen_s")


def check_fit_log(model: Model, path: str) -> None:
    """The fit log's numbers a baseline is read by: the ridge weight and the chosen structure lag, numbers > 0
    (the weight >= 0) where given."""
    for key, low in (("ridge_weight", 0.0), ("structure_lag_chosen_s", 1e-300)):
        if key in (model.fit or {}):
            value = _number(model, key)
            if value is None or not np.isfinite(value) or value < low:
                raise UserError(f"{path}: field 'fit.{key}': expected a number {'>= 0' if low == 0 else '> 0'}, "
                                f"found {model.fit[key]!r}")


def _arrays(model: Model, inputs: dict, precision: str) -> tuple:
    """The precision's type, the coefficients and the input columns in it: what the loop starts from."""
    f = np.float32 if precision == "f32" else np.float64
    coef = {name: f(model.coef(name, precision)) for name in model.coefficients}
    temps = [np.asarray(inputs[s.name], f) for s in model.signals("temperature")]
    te = np.asarray(inputs[model.signals("ambient")[0].name], f)
    n = np.asarray(inputs[model.signals("speed")[0].name], f)
    feed = np.asarray(inputs[model.signals("feed")[0].name], f) if has(model, "feed_axis_heat") else None
    return f, coef, temps, te, n, feed


def predict(model: Model, inputs: dict, precision: str) -> dict:
    """Reference in binary32 ('f32') or float64 ('f64'), in the block's order: models/lumped_kernel.py's loop."""
    return {model.target.name: kernel_arguments(model, inputs, precision)[0]}


def kernel_arguments(model: Model, inputs: dict, precision: str, state=None):
    """(the reference loop's output, its state) for these calls from `state` (None: from the first call)."""
    f, coef, temps, te, n, feed = _arrays(model, inputs, precision)
    gear, cool = has(model, "gear_ratio_switch"), has(model, "coolant_switching")
    flags = Flags(gear=gear, cool_on=cool, stop=has(model, "stop_convection"), slow=has(model, "slow_structure"),
                  amb=has(model, "ambient_coupling"), structure="AS" in coef, feed=feed is not None, load="H_1" in coef,
                  filtered=any(name.startswith("KF_") for name in coef), gear_lag=gear and "AGr" in coef,
                  cool_lag=cool and "ACl" in coef)
    table = [(coef[f"node_{m}"], coef[f"heat_{m}"], coef[f"slope_{m}"]) for m in range(1, segments(model) + 1)]
    state = state or LumpedState(len(temps), f)
    out = lumped_loop(temps, te, n, feed, flags, coef, table, model.settings.get("relay_sensor", 1) - 1, f, state)
    return out, state


def _fit(parts, request, names, dt, progress):
    """The identified baseline (no effects) on every run: physics/identify.py."""
    ridge.refuse_flat(np.vstack([part.temps for part in parts]), names)
    runs = [sim_.Series(dt, np.arange(len(part.target)) * dt, part.speed, part.ambient, part.temps, tuple(names),
                        part.target) for part in parts]
    fitted, measured = identify.fit(runs, progress)  # a block on any training split (identify.py)
    coefficients_, settings = coefficients(fitted, dt)
    return coefficients_, settings, {
        "method": "lumped-mass model identified by least one-step prediction error (steady-state Kalman filter on "
                  "the readings); displacement map with structure lag and ridge weight chosen by forward validation",
        **measured}


def check_settings(model: Model, path: str) -> None:
    """The relay's sensor and each effect's sensor are temperature inputs of the model; every lag decays."""
    s, temps = model.settings, len(model.signals("temperature"))
    sensors = s.get("sensors")
    if sensors is not None and (not isinstance(sensors, list) or len(sensors) != temps
                                or not all(isinstance(x, dict) for x in sensors)):
        raise UserError(f"{path}: field 'settings.sensors': expected a list of {temps} objects, one per temperature "
                        f"input")
    if s.get("relay_sensor", 1) > temps:
        raise UserError(f"{path}: field 'settings.relay_sensor': {s['relay_sensor']} but the model has {temps} "
                        f"temperature inputs")
    for i, effect in enumerate(s.get("effects", [])):
        if effect.get("sensor") is not None and not 1 <= effect["sensor"] <= temps:
            raise UserError(f"{path}: field 'settings.effects[{i}].sensor': {effect['sensor']} but the model has "
                            f"{temps} temperature inputs (numbered from 1)")
    for pair, effect, what in EFFECT_LAGS:  # an effect's own lag: a pair, of that effect
        lag = [name for name in pair if name in model.coefficients]
        if lag and (len(lag) == 1 or not has(model, effect)):
            raise UserError(f"{path}: field 'coefficients': {' and '.join(lag)} without " + (
                f"settings.effects listing {effect}, whose {what} lag it is" if len(lag) == 2 else
                f"{(set(pair) - set(lag)).pop()}; the {what} lag needs both"))
    decays.check(model, path)
    table, nonlinear = int(s.get("speed_table_segments", 0)), has(model, "nonlinear_speed_heat")
    if bool(table) != nonlinear:  # the table is that effect's heat: one without the other is an edited file
        raise UserError(f"{path}: field 'settings.speed_table_segments': {table}, but settings.effects "
                        + ("does not list nonlinear_speed_heat, whose speed heat table it is" if table else
                           "lists nonlinear_speed_heat, which needs a speed heat table of at least 1 segment"))
    for stem in ("node", "heat", "slope"):  # the table's rows: exactly as many as it has segments
        rows = sum(1 for name in model.coefficients if name.startswith(f"{stem}_"))
        if rows != table or any(f"{stem}_{m}" not in model.coefficients for m in range(1, table + 1)):
            raise UserError(f"{path}: field 'settings.speed_table_segments': {table}, but the file has {rows} "
                            f"{stem}_ coefficients; expected {stem}_1 .. {stem}_{table}" if table else
                            f"{path}: field 'coefficients': {rows} {stem}_ coefficients but no speed table")


class StreamCore:
    """predict with the simulation's state kept (LumpedState)."""

    def __init__(self, model: Model, precision: str, f):
        self.f, self.target, self.model, self.precision = f, model.target.name, model, precision
        self.state = None

    def __call__(self, running: dict, fused_valid: dict) -> dict:
        out, self.state = kernel_arguments(self.model, running, self.precision, self.state)
        return {self.target: out}


SETTINGS_SCHEMA = {
    "type": "object",
    "properties": {"effects": {"type": "array", "maxItems": 32,
                               "items": {"type": "object", "required": ["name"],
                                         "properties": {"name": {"type": "string"},
                                                        "sensor": {"type": ["integer", "null"], "minimum": 1}}}},
                   "relay_sensor": {"type": "integer", "minimum": 1},
                   "speed_table_segments": {"type": "integer", "minimum": 0, "maximum": 4096}}}


KIND = Kind("lumped", 9, "000", _fit, predict, roles=("speed", "ambient"), ambient_apart=True, auto="iterative",
            settings_schema=SETTINGS_SCHEMA, check_settings=check_settings, stream_core=StreamCore,
            structure=lambda model: {**({"gear_floor": GEAR_FLOOR_RPM} if "AGr" in model.coefficients else {}),
                                     **({"cool_floor": COOL_FLOOR} if "ACl" in model.coefficients else {})})
