"""Piecewise weighted model library over the ambient temperature (paper 001).

One regression model per ambient node (5 °C grid over 0-40 °C), each fitted on the batches that
started at that node's ambient temperature. In use, the ambient temperature t at the first call
picks the two neighbouring nodes Ta <= t <= Tb and the prediction is eq. (1):
    y = ya*(Tb - t)/(Tb - Ta) + yb*(t - Ta)/(Tb - Ta)
Outside the library's range the nearest node's model is used alone.
"""
from __future__ import annotations

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.models.kind import Kind
from thermoplc.models.kinds.mlr import least_squares
from thermoplc.models.model import Coefficient, Model

NODE_SPACING_C = 5.0
NODE_RANGE_C = (0.0, 40.0)


def node_of(ambient_c: float) -> float:
    node = round(ambient_c / NODE_SPACING_C) * NODE_SPACING_C
    return float(min(max(node, NODE_RANGE_C[0]), NODE_RANGE_C[1]))


def fit_piecewise(batches: list[tuple[np.ndarray, np.ndarray, np.ndarray]], names: list[str]):
    """batches: (temps (rows, sensors), ambient, target) training rows per file."""
    groups: dict[float, list] = {}
    for temps, ambient, target in batches:
        measured = np.isfinite(target)  # a probed target: its measured rows only
        groups.setdefault(node_of(float(ambient[0])), []).append(((temps - temps[0])[measured], target[measured],
                                                                   float(ambient[0])))
    coefficients: dict[str, Coefficient] = {}
    settings = {"nodes": []}
    for m, node in enumerate(sorted(groups), start=1):
        members = groups[node]
        beta, fitted = least_squares(np.vstack([d for d, _, _ in members]), np.concatenate([y for _, y, _ in members]), names)
        coefficients[f"node_{m}"] = Coefficient.of(node)
        coefficients[f"beta0_{m}"] = Coefficient.of(beta[0])
        for i, b in enumerate(beta[1:], start=1):
            coefficients[f"beta_{i}_{m}"] = Coefficient.of(b)
        settings["nodes"].append({"node_C": node, "batches": len(members),
                                  "initial_ambient_C": [a for _, _, a in members], **fitted})
    log = {"method": "least squares per ambient node (paper 001 eq. 1), ridge weight by forward validation", "node_spacing_C": NODE_SPACING_C}
    return coefficients, settings, log


def node_count(model: Model) -> int:
    return sum(1 for name in model.coefficients if name.startswith("node_"))


def select(nodes: list, t):
    """Indices (a, b) of the neighbouring nodes with nodes[a] <= t <= nodes[b], as the block's IF chain."""
    if t <= nodes[0]:
        return 0, 0
    for j in range(1, len(nodes)):
        if t <= nodes[j]:
            return j - 1, j
    return len(nodes) - 1, len(nodes) - 1


def predict(model: Model, inputs: dict, precision: str) -> dict:
    """Reference in the block's order: weights latched at the first call, then
    E = Wa*Ya + Wb*Yb with Y = beta0[m] + beta_1[m]*(T_1 - T0_1) + ..."""
    f = np.float32 if precision == "f32" else np.float64
    temps = model.signals("temperature")
    count = node_count(model)
    coef = lambda name: f(model.coef(name, precision))
    nodes = [coef(f"node_{m}") for m in range(1, count + 1)]
    t = np.asarray(inputs[model.signals("ambient")[0].name], f)[0]
    a, b = select(nodes, t)
    if a == b:
        wa, wb = f(1.0), f(0.0)
    else:
        wa = (nodes[b] - t) / (nodes[b] - nodes[a])
        wb = (t - nodes[a]) / (nodes[b] - nodes[a])
    rises = [np.asarray(inputs[s.name], f) - np.asarray(inputs[s.name], f)[0] for s in temps]

    def node_model(m: int):
        y = np.full(len(rises[0]), coef(f"beta0_{m + 1}"), f)
        for i, rise in enumerate(rises, start=1):
            y = y + coef(f"beta_{i}_{m + 1}") * rise
        return y
    return {model.target.name: wa * node_model(a) + wb * node_model(b)}


def _fit(parts, request, names, dt, progress):
    return fit_piecewise([(p.temps, p.ambient, p.target) for p in parts], names)


def check_settings(model: Model, path: str) -> None:
    """The nodes of the settings are the node_m coefficients, strictly increasing."""
    s = model.settings
    nodes = [model.coefficients[f"node_{m}"].f64 for m in range(1, len(s["nodes"]) + 1)
             if f"node_{m}" in model.coefficients]
    if len(nodes) != sum(1 for name in model.coefficients if name.startswith("node_")) \
            or nodes != [n["node_C"] for n in s["nodes"]] or any(b <= a for a, b in zip(nodes, nodes[1:])):
        raise UserError(f"{path}: field 'coefficients': node_1.. {nodes} must be the settings.nodes' node_C "
                        f"{[n['node_C'] for n in s['nodes']]}, strictly increasing")


SETTINGS_SCHEMA = {
    "type": "object",
    "required": ["nodes"],
    "properties": {"nodes": {"type": "array", "minItems": 1, "maxItems": 64,
                             "items": {"type": "object", "required": ["node_C"],
                                       "properties": {"node_C": {"type": "number"}}}}}}

KIND = Kind("piecewise", 3, "001", _fit, predict, roles=("ambient",), settings_schema=SETTINGS_SCHEMA,
            structure=lambda model: {"one": 1.0},  # the weight of a single node
            check_settings=check_settings)
