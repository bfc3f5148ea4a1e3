"""Sensor offset: a constant offset on one temperature sensor's reading (tried on each sensor).

Term: the sensor reads its temperature plus `offset_K`; the simulation starts from the first
reading less the offset."""
from __future__ import annotations

import numpy as np

from thermoplc.physics.effects.definition import EffectDefinition


def describe(sim, series) -> dict:
    sensor = sim.sensor_of("sensor_offset")
    return {"column": series.names[sensor], "offset_K": sim.sensors[sensor].offset_K}


def draw(rng: np.random.Generator, clean: dict, train: slice, machine) -> dict:
    return {"column": str(rng.choice(machine.DIAGNOSED)),
            "offset_K": float(rng.choice([-1.0, 1.0]) * rng.uniform(0.4, 1.5))}


def untestable(train) -> str | None:
    return ("a constant offset reads as a standstill heat load at that sensor, which the baseline fits per "
            "sensor (a real machine is rarely at the air's temperature with the spindle still), and the "
            "displacement follows temperature rises from the first call: no data can tell the two apart")


EFFECT = EffectDefinition(
    name="sensor_offset", rank=5, bounds=(("offset_K", -100.0, 100.0),), description="a constant offset on one temperature sensor",
    defaults=(("column", "T_bearing"), ("offset_K", 1.0)),
    part="reading", per_sensor=True, added_parameters=lambda sensors: 1,
    describe=describe, draw=draw, untestable=untestable,
    reading_size_K=lambda sensor, series: abs(sensor.offset_K),
    reading_column=lambda series, decay: ("offset_K", 1.0 - decay))  # the start's share of the offset decays
