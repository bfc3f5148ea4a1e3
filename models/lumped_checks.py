"""What a `lumped` model file must hold before its block is built or run: effects on sensors the model
has, their coefficients in pairs, and every decay that keeps the simulation bounded."""
from __future__ import annotations

import re

from thermoplc.base.errors import UserError
from thermoplc.models.model import Model
from thermoplc.physics.displacement import displacement_terms

PER_SENSOR_DECAY = re.compile(r"(A|As)_\d+")
PER_SENSOR_COMPLEMENT = re.compile(r"(B|Bs)_\d+")


def effect_names(model: Model) -> tuple[str, ...]:
    return tuple(e["name"] for e in model.settings.get("effects", ()))


def has(model: Model, name: str) -> bool:
    return name in effect_names(model)


def check_settings(model: Model, path: str) -> None:
    """The relay's sensor and each effect's sensor are temperature inputs of the model; every lag's pair is
    whole and bounded; the speed table matches its effect."""
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
    lag = {name: model.coef(name, "f64") for name in ("AGr", "BGr") if name in model.coefficients}
    if lag and (len(lag) == 1 or not has(model, "gear_ratio_switch")):  # the gear heat's lag: a pair, of that effect
        raise UserError(f"{path}: field 'coefficients': {' and '.join(lag)} without " + (
            "settings.effects listing gear_ratio_switch, whose heat lag it is" if len(lag) == 2 else
            f"{({'AGr', 'BGr'} - set(lag)).pop()}; the gear heat's lag needs both"))
    _check_decays(model, path)
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


def _check_decays(model: Model, path: str) -> None:
    """Each lag's decay per call a = exp(-dt/tau) lies in [0, 1) and its complement 1 - a in (0, 1]: a decay
    of 1 or more integrates its input without bound (the block's state grows until it overflows), a
    negative one makes the state ring."""
    shared = {"AS": "BS", "AGr": "BGr", **{term.pole[0]: term.pole[1] for term in displacement_terms()}}
    for name in model.coefficients:
        decay = PER_SENSOR_DECAY.fullmatch(name) or name in shared
        if not decay and not (PER_SENSOR_COMPLEMENT.fullmatch(name) or name in shared.values()):
            continue
        value = model.coef(name, "f64")
        if not (0.0 <= value < 1.0 if decay else 0.0 < value <= 1.0):
            raise UserError(f"{path}: field 'coefficients.{name}': {value!r}; expected "
                            + ("a decay per call exp(-dt/tau) in [0, 1)" if decay else
                               "the complement 1 - exp(-dt/tau) of a decay per call, in (0, 1]")
                            + ": a lag's state would otherwise grow without bound or ring")
