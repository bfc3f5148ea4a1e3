"""Effect parameters drawn from physically plausible ranges, so a diagnosis is judged on more
than the defaults it was developed on (benchmarks/diagnose.py, tests).

Ranges that depend on the machine's own data (a gear threshold between the speeds it runs, coolant
thresholds inside the temperatures its spindle reaches) are read off the clean recording of the
same seed, on the rows the diagnosis trains on.
"""
from __future__ import annotations

from types import ModuleType

import numpy as np

from thermoplc.models.effects import Effect

RUNNING_RPM = 1.0


def _gear(clean: dict, train: slice, rng: np.random.Generator) -> dict:
    """A threshold between two speeds the machine runs at in training (both sides occupied)."""
    n = clean["n_rpm"][train]
    levels = np.unique(np.round(n[n > RUNNING_RPM], -1))
    low, high = np.quantile(levels, [0.25, 0.75]) if len(levels) > 2 else (levels.min(), levels.max())
    inside = levels[(levels >= low) & (levels <= high)]
    below = rng.choice(inside[:-1]) if len(inside) > 1 else levels[0]
    above = levels[levels > below][0]
    return {"threshold_rpm": float(below + rng.uniform(0.2, 0.8) * (above - below)),
            "ratio": float(rng.uniform(1.3, 3.0))}


def _coolant(clean: dict, train: slice, rng: np.random.Generator, column: str) -> dict:
    """On between the 55th and 80th percentile of the switch sensor's training temperatures, off
    1.5-4 K below: the relay switches several times; cooling 2-6 K of steady rise."""
    t = clean[column][train]
    on = float(np.quantile(t, rng.uniform(0.55, 0.8)))
    gap = min(rng.uniform(1.5, 4.0), 0.8 * (on - float(np.quantile(t, 0.1))))
    return {"on_C": on, "off_C": on - max(gap, 0.5), "cooling_K": float(rng.uniform(2.0, 6.0))}


def draw(name: str, machine: ModuleType, clean: dict, train_rows: int, seed: int) -> Effect:
    """`name` with parameters drawn for this machine and seed (defaults for what is not drawn)."""
    rng = np.random.default_rng([seed, sum(map(ord, name))])
    train = slice(0, train_rows)
    sensors = machine.DIAGNOSED
    if name == "gear_ratio_switch":
        values = _gear(clean, train, rng)
    elif name == "coolant_switching":
        values = _coolant(clean, train, rng, machine.COOLANT_SENSOR)
    elif name == "nonlinear_speed_heat":
        values = {"exponent": float(rng.uniform(1.3, 2.2)), "reference_rpm": float(np.median(
            clean["n_rpm"][train][clean["n_rpm"][train] > RUNNING_RPM]))}
    elif name == "slow_structure":
        values = {"tau_h": float(rng.uniform(2.0, 12.0)), "um_per_K": float(rng.uniform(5.0, 25.0))}
    elif name == "ambient_coupling":
        values = {"tau_h": float(rng.uniform(1.0, 8.0)),
                  "um_per_K": float(rng.choice([-1.0, 1.0]) * rng.uniform(5.0, 15.0))}
    elif name == "sensor_offset":
        values = {"column": str(rng.choice(sensors)),
                  "offset_K": float(rng.choice([-1.0, 1.0]) * rng.uniform(0.4, 1.5))}
    elif name == "sensor_drift":
        values = {"column": str(rng.choice(sensors)),
                  "rate_K_per_h": float(rng.choice([-1.0, 1.0]) * rng.uniform(0.02, 0.1))}
    elif name == "feed_axis_heat":
        values = {"tau_h": float(rng.uniform(0.3, 2.0)), "um_per_K": float(rng.uniform(2.0, 6.0))}
    elif name == "stop_convection":
        values = {"factor": float(rng.uniform(1.8, 4.0))}
    else:
        raise ValueError(name)
    text = ",".join(f"{k}={v}" for k, v in values.items())
    return Effect.parse(f"{name}:{text}")
