"""The record of one model kind: everything the generic code (fit, model file, references,
streaming, auto) needs to know about a kind, declared once in the kind's own module.

A kind module ends with `KIND = Kind(...)` (grey.py declares two), in `models/kinds/`, whose `__init__.py` finds them.
The block lowering is the generator's side of the same kind and is registered there
(`generator/lower_*.py::LOWERINGS`), so the models import nothing of the generator.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from thermoplc.base.values import number_problem

if TYPE_CHECKING:
    from thermoplc.models.model import Model


@dataclass(frozen=True)
class Part:
    """The training rows of one run (one recording), by role: what a kind's fitter receives, one per
    run. The block starts afresh at a run's first row, so every kind takes its rises, lags, sums and
    filter states from there. A probed target is NaN between its measurements: a fitter fits on the
    measured rows (`measured`) with its inputs at the full rate."""
    temps: np.ndarray  # (rows, sensors)
    target: np.ndarray
    extra: np.ndarray  # (rows, further targets)
    speed: np.ndarray | None
    ambient: np.ndarray | None

    @property
    def measured(self) -> np.ndarray:
        """Rows where the target (and every further target) was measured."""
        return np.isfinite(self.target) & np.all(np.isfinite(self.extra), axis=1)

    @property
    def rises(self) -> np.ndarray:
        """Each temperature's rise since the run's first row, as the block takes it."""
        return self.temps - self.temps[0]

    def filled_target(self) -> np.ndarray:
        """The target at every row for a fit that needs it so (running sums of the grey models): linear
        between measurements, held before the first and after the last."""
        measured = np.flatnonzero(np.isfinite(self.target))
        if len(measured) == len(self.target):
            return self.target
        return np.interp(np.arange(len(self.target)), measured, self.target[measured])


def measured_rows(parts: list[Part], columns: Callable[[Part], np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The fit's design and target pooled over runs: `columns(part)` is computed on each run at the full
    rate (its own first row, its own lags), then only the measured rows are kept and stacked."""
    designs = [np.asarray(columns(p), float).reshape(len(p.target), -1)[p.measured] for p in parts]
    return np.vstack(designs), np.concatenate([p.target[p.measured] for p in parts])


def measured_counts(parts: list[Part]) -> list[int]:
    """Each run's measured rows, in the order `measured_rows` stacks them: the runs a fit may leave out."""
    return [int(np.count_nonzero(p.measured)) for p in parts]


@dataclass(frozen=True)
class Increments:
    """Declared by a kind whose prediction is beta0 plus slopes times columns of its inputs: the probe fusion
    refits those slopes on the change since the last probing (fitting/probe_refit.py)."""
    columns: Callable[[Part, dict], np.ndarray]  # (part, the model's settings) -> (rows, slopes), as the fit takes them
    slopes: Callable[[dict, int], list[str]]  # (settings, sensors) -> the slopes' coefficient names, column order


# fit(parts, request, temperature names, sample period s, progress) -> (coefficients, settings, fit log)
Fitter = Callable[[list[Part], Any, list[str], float, Any], tuple[dict, dict, dict]]
# predict(model, inputs by name, "f32" | "f64"[, fused_valid]) -> outputs by name
Predictor = Callable[..., dict]


def guard_kind(role: str, fused_guards: bool) -> str:
    """How the block guards an input of `role`: 'fused' (a temperature the kind's own filter judges), 'temperature'
    (range, jump and stuck check, held at its last good value) or 'range' (models/safety.py::Guard)."""
    roles = set(role.split(","))
    if roles & {"temperature", "ambient"}:
        return "fused" if fused_guards and "temperature" in roles else "temperature"
    return "range"


def fault_key(input_name: str) -> str:
    """The key of an input's per-call fault flags among a reference's outputs: no ST name (the block
    names the output, contract/outputs.py), so the models know nothing of the block's naming."""
    return f"fault:{input_name}"


def _always(model: "Model") -> bool:
    return True


def _no_structure(model: "Model") -> dict:
    return {}


def _no_conflict(option: Callable[[str], Any], field: str) -> str | None:
    return None


def _no_settings_check(model: "Model", path: str) -> None:
    """Kinds whose settings the JSON schema describes completely."""


@dataclass(frozen=True)
class KindOption:
    """One of a kind's own fit options, declared by its record: `fit` builds its flag, help and check from this,
    `FitRequest.settings` carries it and the fitter reads it with `request.option(field)`. Kinds that read the
    same option declare the same record (kalman and bpnn share the GA's, models/ga.py)."""
    field: str  # its key in FitRequest.settings
    flag: str  # its command-line option
    default: Any
    help: str  # argparse help; "%(default)s" shows the default
    number: tuple[type, float, float, str] | None = None  # a number: int or float, its range, what it counts
    choices: tuple[str, ...] | None = None  # else one of these words
    metavar: str | None = None
    column: tuple[str, str] | None = None  # its value names a column the block reads: (role, unit)
    owned: str | None = None  # refused for any other kind, in these words ("--time-bins is")

    def problem(self, value: Any) -> str | None:
        """Why `value` is not one this option takes, in the words the command line uses, or None. None is
        taken only where it is the default (a limit found from the data, no tool length column)."""
        if value is None:
            return None if self.default is None else f"expected a value, found None (its default is {self.default!r})"
        if self.choices is not None and value not in self.choices:
            return f"expected one of {', '.join(self.choices)}, found {value!r}"
        if self.number is not None:  # the command line's check (base/values.py)
            problem = number_problem(value, *self.number)
            if problem:
                return problem
        if self.column is not None and not isinstance(value, str):
            return f"expected a column name, found {value!r}"
        return None


@dataclass(frozen=True)
class Kind:
    name: str  # the model file's `kind` and `fit --model NAME`
    order: int  # position in listings (help, errors, the schema enum): the papers' order, not the alphabet
    paper: str  # the paper it comes from (docs/references.md): "000" .. "004"
    fit: Fitter
    predict: Predictor  # the reference: float64 (ideal) or binary32 (what the block computes), per call
    roles: tuple[str, ...] = ()  # input roles the block reads beside its temperatures
    # with fused_guards the Kalman filter itself handles a faulty temperature (its gain goes to 0): the
    # predictor takes the per-call validity of each temperature, no hold is put in front of it, and it
    # returns each temperature's fault flags under fault_key(name)
    fused_guards: bool = False
    ambient_apart: bool = False  # the ambient drives every temperature, so it may not be one of them
    # FitRequest fields no other kind may set: (field, what the error says of it, with its verb)
    owns_options: tuple[tuple[str, str], ...] = ()
    # its own options (beside the target, the temperatures and the training part): `fit` refuses one given
    # for a kind that does not read it
    options: tuple[KindOption, ...] = ()
    auto: str | None = None  # "closed-form" (tried on every sensor set), "iterative" (on the best), None
    # how many of --temps `auto` lets it choose on a campaign: a ridge-shrunk linear map takes more sensors
    # to its gain (FL_THERMAL in 6 h runs: mlr and dlag 1.0-1.3x a ridge on all 15 with 8, 1.3-1.5x with 4),
    # GM(1,N) gets worse past 4 (ch3 5.2 -> 8.8 um)
    auto_sensors: int = 4
    settings_schema: dict | None = None  # JSON schema of the model file's `settings` for this kind
    check_settings: Callable[["Model", str], None] = _no_settings_check  # what the schema cannot say
    # the streamed reference: a class (model, precision, dtype) -> callable(running, fused_valid) keeping the
    # kind's memory between chunks; None: the kind depends on the current and the first call only
    stream_core: type | None = None
    streamable: Callable[["Model"], bool] = _always
    increments: Increments | None = None  # a linear kind: its slopes may be refitted for a fused block
    # the options under which it fits every sensor given through one ridge (base/ridge.py), ranked so by `auto`
    # beside the chosen-sensor candidates: () where it always does (mlr, dlag), None where it cannot
    shrunk: tuple[tuple[str, Any], ...] | None = None
    # why an option it reads is refused beside the others given: (read an option by field, field) -> reason or None
    conflict: Callable[[Callable[[str], Any], str], str | None] = _no_conflict
    # what its settings fix that its block counts with (a ring buffer's length, an interval count), keyed by
    # what it is ("len", "lag_2", "k_1"); the contract names each in the block (contract/constants.py)
    structure: Callable[["Model"], dict] = _no_structure

    def reads(self, field: str) -> bool:
        """Whether its fit reads this FitRequest field or option, one it owns or reads (the input roles,
        `--speed` and `--ambient`, name columns of the recording, not options of a fit)."""
        return field in dict(self.owns_options) or any(option.field == field for option in self.options)
