"""Synthetic machines with known truth (docs/diagnosis.md): tests, demos and benchmarks run on them.

Each machine is a module with NAME, DESCRIPTION, SENSORS (its temperature columns), DIAGNOSED
(the ones a diagnosis is given), COOLANT_SENSOR (the node the coolant relay reads),
COLUMN_DEFAULTS (the sensor an offset or drift lands on unless told) and
`simulate(hours, seed, dt, ambient_start, ambient_swing, faults, constant_rpm, effects, noise, ambient_level,
ambient_step_s)`
returning the columns by name. Two machines written apart keep the diagnosis honest: a method
tuned on one is measured on the other.
"""
from __future__ import annotations

from importlib import import_module
from types import ModuleType

from thermoplc.base.errors import UserError

MACHINES = {"cascade": "thermoplc.machines.cascade", "portal": "thermoplc.machines.portal"}
DEFAULT = "cascade"


def machine(name: str) -> ModuleType:
    if name not in MACHINES:
        raise UserError(f"--machine {name!r}: expected one of {', '.join(MACHINES)}")
    return import_module(MACHINES[name])
