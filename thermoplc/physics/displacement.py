"""The displacement of the lumped-mass model: regressed on the simulated temperatures, the structure
that lags them and each displacement effect's term (its record's DisplacementTerm); the time constants
searched, the weights by least squares (see physics/simulation.py for the equations)."""
from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from thermoplc.physics.effects import definition_of, registry
from thermoplc.physics.effects.definition import DisplacementTerm
from thermoplc.physics.fitted import Simulation
from thermoplc.physics.primitives import (HOUR, DisplacementParams, Series, first_temperatures, lag_columns,
                                          least_squares, minimize, minimize_scalar, pole)

GRID_POINTS = 13  # per time constant searched anew in the displacement
POLISHED_STARTS = 4


def term_columns(series: Series, sim: Simulation, name: str, temps: np.ndarray, start: np.ndarray) -> np.ndarray:
    """The columns of displacement effect `name`'s term for these temperatures (from `start`), before its weights."""
    count = temps.shape[1] if definition_of(name).displacement.per_sensor else 1
    taus = {**fitted_taus(sim, series), "t0": start}
    return np.column_stack(displacement_columns(series, temps, taus, ((name, None),))[-count:])


def displacement_terms(effects=None) -> list[DisplacementTerm]:
    """The displacement terms these effects add (every effect's when None), in the order of their
    records (the columns' order)."""
    names = None if effects is None else {e for e, _ in effects}
    return [record.displacement for name, record in registry().items()
            if record.displacement and (names is None or name in names)]


def displacement_columns(series, temps, taus: dict, effects):
    """Rises of the simulated temperatures (ambient part included), of the structures lagging them,
    and each displacement effect's columns (its record's term)."""
    t0 = taus["t0"]  # physical temperatures before the first row
    k = temps.shape[1]
    columns = [temps[:, i] - t0[i] for i in range(k)]
    lagged = temps
    if taus["struct"] is not None:
        lagged = lag_columns(temps, pole(taus["struct"], series.dt), t0)
        columns += [lagged[:, i] - t0[i] for i in range(k)]
    for term in displacement_terms(effects):
        columns += term.columns(series, temps, lagged, t0, taus[term.key])
    return columns


def fit_displacement(series: Series, temps: np.ndarray, t0: np.ndarray, effects, structure_lag: bool = True,
                     start: DisplacementParams | None = None) -> tuple[DisplacementParams, float]:
    """The displacement's time constants by grid search and polish, its weights by least squares on `temps`
    (rises from `t0`); returns them and the squared error, starting from `start`'s time constants."""
    terms = displacement_terms(effects)
    wanted = (["struct"] if structure_lag else []) + [term.key for term in terms]
    bounds = {"struct": (np.log(600.0), np.log(48 * HOUR)),
              **{term.key: (np.log(term.search_s[0]), np.log(term.search_s[1])) for term in terms}}
    known = {}
    if start is not None:
        known = {"struct": start.tau_struct_s, **{term.key: getattr(start, term.tau_field) for term in terms}}
    k = temps.shape[1]

    def taus_of(x):
        taus = {"t0": t0, "struct": None, **{name: float(np.exp(np.clip(v, *bounds[name]))) for name, v in zip(wanted, x)}}
        for term in terms:  # e.g. a slow lag kept well above the structure's, so the two cannot swap roles
            if term.lowest_s is not None:
                taus[term.key] = max(taus[term.key], term.lowest_s(taus["struct"]))
        return taus

    def cost(x):
        columns = [np.ones(series.rows)] + displacement_columns(series, temps, taus_of(x), effects)
        return least_squares(series.target, columns)[1]

    # a grid over what is new, jointly with the structure's time constant (a slow lag added to a
    # structure that had settled between the two true time constants must be able to move it)
    axes = []
    for name in wanted:
        values = list(np.linspace(*bounds[name], GRID_POINTS))
        if known.get(name):
            joint = name == "struct" and any(not known.get(w) for w in wanted)
            values = [np.log(known[name])] + (values if joint else [])
        axes.append(values)
    grid = sorted(itertools.product(*axes), key=lambda x: cost(list(x)))
    if len(wanted) == 1:
        lo, hi = bounds[wanted[0]]
        x0 = grid[0][0]
        x = [minimize_scalar(lambda g: cost([g]), bounds=(max(lo, x0 - 1.5), min(hi, x0 + 1.5)),
                             method="bounded", options={"xatol": 1e-5}).x]
    elif wanted:  # the valleys are narrow and curved: polish the best few grid points, keep the best
        polished = [minimize(cost, list(x0), method="Nelder-Mead",
                             options={"xatol": 1e-4, "fatol": 1e-9, "maxiter": 400}) for x0 in grid[:POLISHED_STARTS]]
        x = min(polished, key=lambda result: result.fun).x
    else:
        x = []
    taus = taus_of(x)
    columns = [np.ones(series.rows)] + displacement_columns(series, temps, taus, effects)
    coef, sse = least_squares(series.target, columns)
    return displacement_params(coef, k, taus, terms), sse


def displacement_params(coef, k: int, taus: dict, terms, ridge_weight: float | None = None,
                        chosen_s: float | None = None) -> DisplacementParams:
    """The map's parameters from its coefficients in column order (offset, a weight per sensor, per sensor
    on the structure lag when `taus["struct"]` is set, then each term's) and the time constants."""
    coef = [float(c) for c in coef]
    lagged = k if taus["struct"] is not None else 0
    params = DisplacementParams(tau_struct_s=taus["struct"], beta0=coef[0], beta=tuple(coef[1:1 + k]),
                                gamma=tuple(coef[1 + k:1 + k + lagged]), ridge_weight=ridge_weight,
                                tau_struct_chosen_s=chosen_s)
    rest = coef[1 + k + lagged:]
    for term in terms:
        count = k if term.per_sensor else 1
        weights = tuple(rest[:count]) if term.per_sensor else rest[0]
        params = replace(params, **{term.tau_field: taus[term.key], term.weight_field: weights})
        rest = rest[count:]
    return params


def fitted_taus(sim: Simulation, series: Series) -> dict:
    d = sim.displacement
    return {"t0": first_temperatures(series, sim.sensors), "struct": d.tau_struct_s,
            **{term.key: getattr(d, term.tau_field) for term in displacement_terms()}}
