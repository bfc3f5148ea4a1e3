"""Sensor drift: one temperature sensor's reading drifts linearly with time (tried on each sensor).

Term: the sensor reads its temperature plus `drift * (t - t0)`."""
from __future__ import annotations

import numpy as np

from thermoplc.physics.effects.definition import EffectDefinition
from thermoplc.physics.effects.evidence import HOUR


def describe(sim, series) -> dict:
    sensor = sim.sensor_of("sensor_drift")
    return {"column": series.names[sensor], "rate_K_per_h": sim.sensors[sensor].drift_K_per_s * HOUR}


def draw(rng: np.random.Generator, clean: dict, train: slice, machine) -> dict:
    return {"column": str(rng.choice(machine.DIAGNOSED)),
            "rate_K_per_h": float(rng.choice([-1.0, 1.0]) * rng.uniform(0.02, 0.1))}


EFFECT = EffectDefinition(
    name="sensor_drift", rank=6, bounds=(("rate_K_per_h", -100.0, 100.0),), description="one temperature sensor drifts linearly with time",
    defaults=(("column", "T_motor"), ("rate_K_per_h", 0.05)),
    part="reading", per_sensor=True, added_parameters=lambda sensors: 1,
    describe=describe, draw=draw,
    reading_size_K=lambda sensor, series: abs(sensor.drift_K_per_s) * (series.t[-1] - series.t[0]),
    reading_column=lambda series, decay: ("drift_K_per_s", series.t - series.t[0]))
