"""The record of one named physical effect.

Each effect is declared once, in its own module of this package (`EFFECT = EffectDefinition(...)`):
its parameters and their rules, which part of the lumped-mass simulation it extends, how many
parameters that adds, its fitted parameters in engineering units, the random draw the benchmarks
hide in a synthetic machine, and its evidence rules (what the training data must show, what
fitted values are not the named physics). The generic code (the twin's `--effect`, the model
file, the simulation's bookkeeping, the diagnosis) reads these records instead of branching on
names. Records import nothing heavy at module level: the CLI lists the names before any fit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Any, Callable, Literal, NamedTuple, Protocol

from thermoplc.base.errors import UserError

if TYPE_CHECKING:
    import numpy as np

    from thermoplc.physics.primitives import DisplacementParams, SensorParams, Series, Shared

# where the effect enters the simulation (physics/simulation.py):
#   heat: one more heat input per sensor; speed: how speed becomes heat; pole: the sensors' time
#   constants; reading: one sensor's reading, not the physics; displacement: one more term of it
Part = Literal["heat", "speed", "pole", "reading", "displacement"]
TEXT_PARAMETERS = frozenset({"column"})


class FittedModel(Protocol):
    """What an effect's rules read of a fitted model (physics/fitted.Simulation, which counts its
    parameters through these records: the records name the shape, not the class)."""
    effects: tuple[tuple[str, int | None], ...]
    shared: "Shared"
    sensors: tuple["SensorParams", ...]
    displacement: "DisplacementParams"

    def has(self, name: str) -> bool: ...

    def sensor_of(self, name: str) -> int | None: ...


class Routines(NamedTuple):
    """The lumped model's own routines an effect's search or rule calls back into, handed in by its caller (the
    simulation, the identified model, the diagnosis). An effect module that imported them would close a circle
    at run time: they import this package, whose registry loads the effect modules."""
    simulation: ModuleType  # physics/simulation.py
    displacement: ModuleType  # physics/displacement.py
    identify: ModuleType | None = None  # physics/identify.py; None inside the open-loop simulation it builds on


def _never(*_: Any) -> None:
    return None


@dataclass(frozen=True)
class DisplacementTerm:
    """The term an effect of part 'displacement' adds: a lag with a time constant of its own, searched
    within `search_s`, whose columns the least squares weighs (physics/simulation.py). The names say
    where the fit keeps it and what the lumped block calls its lag and weight (models/kinds/lumped_model.py)."""
    key: str  # its time constant among the searched ones
    tau_field: str  # the field of primitives.DisplacementParams holding the fitted time constant
    weight_field: str  # ... holding its weights: a tuple with a weight per sensor, else one number
    per_sensor: bool
    search_s: tuple[float, float]  # the range its time constant is searched in, seconds
    # (series, temperatures, their structure lag (or the temperatures), temperatures before the
    # first row, time constant) -> its columns, the lag's rise from its start
    columns: Callable[["Series", "np.ndarray", "np.ndarray", "np.ndarray", float], list]
    pole: tuple[str, str]  # the block's coefficients of its lag: decay and complement
    weight: str  # the block's coefficient of its weight (`weight_i` per sensor)
    lowest_s: Callable[[float | None], float] | None = None  # its least time constant, given the structure's

    def weights(self, displacement) -> tuple[float, ...]:
        value = getattr(displacement, self.weight_field)
        return tuple(value) if self.per_sensor else (value,)


@dataclass(frozen=True)
class EffectDefinition:
    """Everything the generic code needs to know about one effect."""
    name: str
    rank: int  # position in every list of effects (the twin's help, the order the diagnosis tries them)
    description: str
    defaults: tuple[tuple[str, float | str], ...]  # the twin's parameters unless told
    part: Part
    added_parameters: Callable[[int], int]  # fitted parameters it adds, given the number of sensors
    describe: Callable[["FittedModel", "Series"], dict]  # its fitted parameters in engineering units
    draw: Callable[["np.random.Generator", dict, slice, Any], dict]  # (rng, clean recording, training rows,
    #                                                                    machine module) -> parameters to hide
    per_sensor: bool = False  # tried on each sensor in turn
    positive: tuple[str, ...] = ()  # parameters that must be above 0
    # (parameter, lowest, highest): what a machine can physically have; beyond it the synthetic
    # machine overflows or the effect is no longer the named physics
    bounds: tuple[tuple[str, float, float], ...] = ()
    check: Callable[[dict], str | None] = _never  # a rule across its parameters
    untestable: Callable[["Series"], str | None] = _never  # why a training part cannot show it
    look_alike: Callable[["Series"], tuple[str, str] | None] = _never  # an effect that fits alike by construction
    # why a fit is not the named physics: (model, training part, routines)
    implausible: Callable[["FittedModel", "Series", Routines], str | None] = _never
    after_fit: Callable[["FittedModel", "Series", Routines], str | None] = _never  # a rule on the fit's own behaviour
    # (model before, model with it, training part, routines) -> (names, why) when an effect added before
    # leaves a fit of this one that the data cannot tell from that effect
    alike_after: Callable[["FittedModel", "FittedModel", "Series", Routines],
                          tuple[tuple[str, ...], str] | None] = _never
    # (model before, model with it) -> (what, the model before changed so) when the baseline's own class, reached
    # further, may fit as well: the effect is named only if it beats that refitted by the BIC margin
    rival: Callable[["FittedModel", "FittedModel"], tuple[str, Any] | None] = _never
    reading_size_K: Callable[["SensorParams", "Series"], float] | None = None  # part "reading": its size
    driven_by: str | None = None  # a recorded signal it needs besides speed and ambient (the feed rate)
    displacement: DisplacementTerm | None = None  # part "displacement": its term
    # where it changes the simulation beyond a term (physics/simulation.py, physics/identified_effects.py):
    # a heat input, (the SensorParams field weighing it, its column) from (series, shared, a closed loop's
    # state or None), or None while its shared parameters are unknown
    heat_input: Callable[..., tuple[str, Any] | None] | None = None
    # part reading: the column its parameter multiplies in the sensor's least squares, (the SensorParams field,
    # the column) from (series, the decay of the sensor's start)
    reading_column: Callable[..., tuple[str, Any]] | None = None
    # its shared parameters searched with the sensors held: (series, shared, effects, starts, routines) -> shared
    # on one series open loop, (runs, shared, effects, sensors, routines) -> shared on the identified model's runs
    search_open_loop: Callable[..., Any] | None = None
    search_identified: Callable[..., Any] | None = None
    # a closed loop (the coolant relay): its state per row switched by the simulated temperature,
    # (series, shared, sensors, effects, routines) -> state or None, and its open-loop fit, searched last,
    # (series, shared, effects, starts, routines) -> (shared, sensors)
    closed_loop: Callable[..., Any] | None = None
    fit_closed_loop: Callable[..., tuple] | None = None

    def __post_init__(self) -> None:
        if (self.part == "displacement") != (self.displacement is not None):
            raise ValueError(f"effect {self.name}: a displacement term belongs to part 'displacement' only")

    def out_of_bounds(self, key: str, value: float) -> str | None:
        """Why `value` is outside the physical range of parameter `key`, or None."""
        for name, low, high in self.bounds:
            if name == key and not low <= value <= high:
                return f"{key} must be within {low:g}..{high:g}, found {value:g}"
        return None

    def parameters_from(self, text: str, rest: str, columns: dict[str, str] | None) -> tuple[tuple[str, float | str], ...]:
        """This effect's parameters, `rest` ('key=value,...') over its defaults; `text` is what the user typed."""
        parameters = dict(self.defaults)
        if columns and self.name in columns:
            parameters["column"] = columns[self.name]
        given = set()
        for item in filter(None, (s.strip() for s in rest.split(","))):
            key, sep, value = item.partition("=")
            key = key.strip()
            if key in given:
                raise UserError(f"--effect {text!r}: {key} is given twice; give each parameter once")
            given.add(key)
            if not sep or key not in parameters:
                raise UserError(f"--effect {text!r}: expected {self.name}[:key=value,...] with keys "
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
            if key in self.positive and parameters[key] <= 0:
                raise UserError(f"--effect {text!r}: {key} must be above 0, found {value.strip()!r}")
            if why := self.out_of_bounds(key, parameters[key]):
                raise UserError(f"--effect {text!r}: {why}")
        if why := self.check(parameters):
            raise UserError(f"--effect {text!r}: {why}")
        return tuple(parameters.items())
