"""The named physical effects (docs/diagnosis.md): one list shared by the twin and the diagnosis.

The twin switches an effect on with its parameters (`--effect NAME[:key=value,...]`); the
diagnosis tests each name as an extension of the lumped-mass simulation. Names are the
user-facing contract, so they live here once.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from thermoplc.base.errors import UserError

# name -> (what it is, the twin's default parameters)
EFFECTS: dict[str, tuple[str, dict]] = {
    "gear_ratio_switch": ("motor heat per rpm changes above a speed threshold (paper 000's 750 rpm gearbox)",
                          {"threshold_rpm": 750.0, "ratio": 1.6}),
    "coolant_switching": ("extra motor cooling switched on/off at temperature thresholds with hysteresis",
                          {"on_C": 27.0, "off_C": 24.0, "cooling_K": 4.0}),
    "nonlinear_speed_heat": ("heat grows as n^p with p != 1", {"exponent": 1.6, "reference_rpm": 1500.0}),
    "slow_structure": ("a second, slow thermal time constant in the displacement", {"tau_h": 16.0, "um_per_K": 20.0}),
    "ambient_coupling": ("the structure follows ambient swings (day/night)", {"tau_h": 3.0, "um_per_K": 10.0}),
    "sensor_offset": ("a constant offset on one temperature sensor", {"column": "T_bearing", "offset_K": 1.0}),
    "sensor_drift": ("one temperature sensor drifts linearly with time", {"column": "T_motor", "rate_K_per_h": 0.05}),
    "feed_axis_heat": ("heat from feed-axis motion (ball screw) moves the tool", {"tau_h": 0.5, "um_per_K": 3.0}),
    "stop_convection": ("cooling differs when the spindle stands (natural vs forced convection)",
                        {"factor": 2.5}),
}
NAMES = tuple(EFFECTS)
TEXT_PARAMETERS = frozenset({"column"})
POSITIVE_PARAMETERS = frozenset({"tau_h", "factor", "ratio", "exponent", "reference_rpm"})


@dataclass(frozen=True)
class Effect:
    """A named effect with its parameters (defaults filled in)."""
    name: str
    parameters: tuple[tuple[str, float | str], ...]

    def get(self, key: str):
        return dict(self.parameters)[key]

    @staticmethod
    def parse(text: str, columns: dict[str, str] | None = None) -> "Effect":
        """NAME[:key=value,...]; `columns` names the sensor an effect with a `column` lands on
        unless told (each machine has its own sensors)."""
        name, _, rest = text.partition(":")
        name = name.strip()
        if name not in EFFECTS:
            raise UserError(f"--effect {text!r}: unknown effect {name!r}; expected one of {', '.join(NAMES)}")
        parameters = dict(EFFECTS[name][1])
        if columns and name in columns:
            parameters["column"] = columns[name]
        for item in filter(None, (s.strip() for s in rest.split(","))):
            key, sep, value = item.partition("=")
            key = key.strip()
            if not sep or key not in parameters:
                raise UserError(f"--effect {text!r}: expected {name}[:key=value,...] with keys "
                                f"{', '.join(parameters)}; found {item!r}")
            if key in TEXT_PARAMETERS:
                parameters[key] = value.strip()
                continue
            try:
                parameters[key] = float(value)
            except ValueError:
                raise UserError(f"--effect {text!r}: {key} must be a number, found {value.strip()!r}") from None
            if not math.isfinite(parameters[key]):
                raise UserError(f"--effect {text!r}: {key} must be a finite number, found {value.strip()!r}")
            if key in POSITIVE_PARAMETERS and parameters[key] <= 0:
                raise UserError(f"--effect {text!r}: {key} must be above 0, found {value.strip()!r}")
        if name == "coolant_switching" and not parameters["on_C"] > parameters["off_C"]:
            raise UserError(f"--effect {text!r}: on_C must be above off_C (the relay's hysteresis)")
        return Effect(name, tuple(parameters.items()))
