"""Named effects as nested extensions of the identified model (physics/identify.py), for `diagnose`.

An effect extends the identified model where it acts. A heat, speed or pole effect changes each
sensor's one-step prediction: its shared parameter (gear threshold, exponent, relay thresholds)
is searched by the one-step prediction error with every sensor's pole, standstill factor and
filter gain held, then each sensor is identified again with it (physics/identify.fit_sensor). A
displacement effect adds its term to the map, refitted by least squares with the structure lag
kept within a grid step of forward validation's choice (`extend_map`).
An effect on one sensor's reading (an offset, a drift) makes that sensor's reading a poor guide
to its temperature: the extension runs that sensor open loop (filter gain 0, fitted as the
simulation fits it, the reading effect among its columns), the others keep their filters.
"""
from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from thermoplc.base import ridge
from thermoplc.physics import displacement, identify
from thermoplc.physics import simulation as sim_
from thermoplc.physics.effects import definition_of, with_part
from thermoplc.physics.effects.definition import Routines
from thermoplc.physics.fitted import Simulation
from thermoplc.physics.primitives import DisplacementParams, Series, Shared

ROUTINES = Routines(simulation=sim_, displacement=displacement, identify=identify)  # what effect searches call back


def _search_shared(runs: list[Series], shared: Shared, effects, sensors) -> Shared:
    """The shared parameters of these effects (gear threshold, speed-heat exponent; a closed loop's thresholds
    last), sensors held: each effect's record searches its own."""
    for record in sim_.records_with(effects, "search_identified"):
        if not record.closed_loop:
            shared = record.search_identified(runs, shared, effects, sensors, ROUTINES)
    loop = sim_.closed_loop_of(effects)
    return shared if loop is None else loop.search_identified(runs, shared, effects, sensors, ROUTINES)


def _fit_sensor(runs: list[Series], i: int, shared: Shared, effects, start, cooling=None):
    """Sensor i identified with the effects; open loop (the simulation's fit) when one of them is an error of
    its reading."""
    if any(s == i for name, s in effects if definition_of(name).part == "reading"):
        if len(runs) != 1:
            raise ValueError("a reading effect is fitted on one run")
        return sim_.fit_sensor(runs[0], i, shared, effects, start, None if cooling is None else cooling[0])[0]
    return identify.fit_sensor(runs, i, shared, effects, start, cooling)


def _fit_sensors(runs: list[Series], shared: Shared, effects, starts) -> tuple:
    """Every sensor fitted with the effects; with a closed loop (a coolant relay) twice, the second time with the
    relay switched by the filtered temperature (as the block switches it) instead of the smoothed reading."""
    sensors = tuple(_fit_sensor(runs, i, shared, effects, p) for i, p in enumerate(starts))
    cooling = [sim_.closed_loop_state(series, shared, sensors, effects) for series in runs]
    if cooling[0] is None:
        return sensors
    return tuple(_fit_sensor(runs, i, shared, effects, p, cooling) for i, p in enumerate(sensors))


# the structure lag is refitted within one step of identify's grid around the time constant forward validation
# chose: that grid is coarse (a factor 1.44), and a candidate must not be credited with what the finer fit gains,
# but a lag far from the chosen one fits the training part and extrapolates badly (FL_THERMAL ch5: 18 h)
STRUCT_STEP = float(np.log(48 * sim_.HOUR / 600.0) / (displacement.GRID_POINTS - 1))


def extend_map(runs: list[Series], temps: list[np.ndarray], t0: list[np.ndarray], effects,
               base: DisplacementParams) -> DisplacementParams:
    """The map with the effects' displacement terms, refitted by least training error with the ridge weight
    of `base` held: the structure lag's time constant (within `STRUCT_STEP` of `base`'s) and each new term's
    by a grid (the known ones from `base` among it) and a polish, the weights by ridge. With no new term this
    is the baseline's own map refitted by the training likelihood every candidate is refitted by, so no
    candidate is credited with what refitting the structure alone gains."""
    terms = sim_.displacement_terms(effects)
    keys = (["struct"] if base.tau_struct_s is not None else []) + [term.key for term in terms]
    chosen = base.tau_struct_chosen_s or base.tau_struct_s  # forward validation's choice, kept through every refit
    bounds = {**({"struct": (np.log(chosen) - STRUCT_STEP, np.log(chosen) + STRUCT_STEP)}
                 if base.tau_struct_s is not None else {}),
              **{term.key: (np.log(term.search_s[0]), np.log(term.search_s[1])) for term in terms}}
    known = {"struct": base.tau_struct_s, **{term.key: getattr(base, term.tau_field) for term in terms}}
    measured = [np.isfinite(series.target) for series in runs]
    y = np.concatenate([series.target[m] for series, m in zip(runs, measured)])
    weight = base.ridge_weight or 0.0

    def taus_of(x) -> dict:
        taus = {"struct": None, **{key: float(np.exp(np.clip(v, *bounds[key]))) for key, v in zip(keys, x)}}
        for term in terms:  # a slow lag stays well above the structure's (the record's rule)
            if term.lowest_s is not None:
                taus[term.key] = max(taus[term.key], term.lowest_s(taus["struct"]))
        return taus

    def design(taus: dict) -> np.ndarray:
        return np.vstack([np.column_stack(displacement.displacement_columns(series, temps[r], {**taus, "t0": t0[r]}, effects))[m]
                          for r, (series, m) in enumerate(zip(runs, measured))])

    def cost(x) -> float:
        d = design(taus_of(x))
        offset, slopes = ridge.ridge(d, y, weight)
        return float(np.sum((y - offset - d @ slopes) ** 2))

    axes = [sorted({*np.linspace(*bounds[key], displacement.GRID_POINTS),
                    *([np.log(known[key])] if known.get(key) else [])}) for key in keys]
    grid = sorted(itertools.product(*axes), key=lambda g: cost(list(g)))
    if len(keys) == 1:
        lo, hi = bounds[keys[0]]
        x0 = grid[0][0]
        x = [sim_.minimize_scalar(lambda g: cost([g]), bounds=(max(lo, x0 - 1.5), min(hi, x0 + 1.5)),
                                  method="bounded", options={"xatol": 1e-5}).x]
    elif keys:
        x = min((sim_.minimize(cost, list(g), method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-9,
                                                                             "maxiter": 400})
                 for g in grid[:displacement.POLISHED_STARTS]), key=lambda result: result.fun).x
    else:
        x = []
    taus = taus_of(x)
    offset, slopes = ridge.ridge(design(taus), y, weight)
    return displacement.displacement_params([offset, *slopes], len(t0[0]), taus, terms, base.ridge_weight,
                                    chosen if base.tau_struct_s is not None else None)


def refit_map(runs: list[Series], sim: Simulation) -> Simulation:
    """`sim` with its map refitted by least training error (`extend_map` with nothing new)."""
    temps = [sim_.temperatures(series, sim.shared, sim.sensors, sim.effects)[1] for series in runs]
    t0 = [sim_.first_temperatures(series, sim.sensors) for series in runs]
    return replace(sim, displacement=extend_map(runs, temps, t0, sim.effects, sim.displacement))


def extend(runs: list[Series], effects, warm: Simulation, polish: bool = False) -> Simulation:
    """The identified model `warm` with these effects (its own and the new ones), refitted on the runs'
    training parts where they act; `polish` refits where every effect acts, from where `warm` stopped. A
    shared parameter is searched with the sensors held, then the sensors with it, `SEARCH_ROUNDS` times: the
    sensors held are those of a model without it (a filter gain of 0.5 that took up the missing heat), so one
    search stops short and a second effect would be credited with the rest."""
    effects = tuple(effects)
    moved = {name for name, _ in effects} - (set() if polish else {name for name, _ in warm.effects})
    shared, sensors = warm.shared, warm.sensors
    if not moved <= with_part("displacement") | with_part("reading"):
        for _ in range(sim_.SEARCH_ROUNDS):
            shared = _search_shared(runs, warm.shared, effects, sensors)
            sensors = _fit_sensors(runs, shared, effects, sensors)
    elif not moved <= with_part("displacement"):
        sensors = _fit_sensors(runs, shared, effects, warm.sensors)
    return _with_map(runs, effects, shared, sensors, warm.displacement)


def _with_map(runs: list[Series], effects, shared: Shared, sensors, base: DisplacementParams) -> Simulation:
    """The model of these effects, shared parameters and sensors, its map refitted on them from `base`."""
    temps = [sim_.temperatures(series, shared, sensors, effects)[1] for series in runs]
    t0 = [sim_.first_temperatures(series, sensors) for series in runs]
    return Simulation(effects, shared, sensors, extend_map(runs, temps, t0, effects, base))


def reidentify(runs: list[Series], model: Simulation) -> Simulation:
    """`model`'s effects with its sensors, shared parameters and map identified again on these runs, from
    `model`'s (the structure lag within one step, `extend_map`): a model diagnosed on one recording and judged
    on another (diagnose --baseline) lends its structure, not its numbers, so no candidate is credited with
    what identifying the sensors on the new data alone gains."""
    shared, sensors = model.shared, model.sensors
    for _ in range(sim_.SEARCH_ROUNDS):
        shared = _search_shared(runs, shared, model.effects, sensors)
        sensors = _fit_sensors(runs, shared, model.effects, sensors)
    return _with_map(runs, model.effects, shared, sensors, model.displacement)
