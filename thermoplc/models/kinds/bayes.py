"""Bayesian network of paper 004: temperatures (parents) -> thermal error (child), discretised.

Each temperature rise dT_i = T_i - T_i[first call] falls into one of K_i equal-width intervals
(values outside the training range go to the outer intervals); the error into intervals of the
width the precision requirement asks for. The conditional probability table comes from counts
with a Dirichlet prior N' = 1: P(D = k | config j) = (1 + N_jk) / (K_D + N_j). The prediction is
the midpoint of the most probable interval (eq. 7). A configuration never seen in training has
no evidence: by default (`unseen="nearest"`) it answers what the nearest seen configuration
answers (fewest interval steps over all sensors; ties to the one seen most often, then the lower
index), with `unseen="frequent"` the interval most frequent overall (the network's own answer:
all its intervals tie). The block holds no probabilities: it finds
each interval by comparisons and reads the prediction from a table indexed by the configuration.

With `parents="ridge"` the network has one temperature parent instead, the ridge fit's prediction from
every temperature's rise (base/ridge.py, its weight chosen leaving out each run) in intervals as wide as
the error's, and its child is what the ridge leaves (the error less that prediction, in intervals
centred on 0): the block outputs the prediction plus the midpoint of the residual's most probable
interval. A network on many sensors needs more configurations than a block can hold and more than
training can fill (FL_THERMAL in 6 h runs, four sensors of 8 intervals: 2.5-3.1 x a ridge on every
sensor); the shrunk map carries the sensors and goes on past the training range, where a table of
errors stops at its outer interval (issue 62: a warmer held-out run), the network the mode of what it leaves.
"""
from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from thermoplc.base.binary32 import round_f32
from thermoplc.base.errors import UserError
from thermoplc.models.kind import Kind, KindOption, Part, measured_counts, measured_rows
from thermoplc.models.kinds.mlr import least_squares, on_rises, weight_by
from thermoplc.models.model import Coefficient, Model

MAX_CONFIGURATIONS = 4096  # table entries in the block
MAX_TABLE_CELLS = 20_000_000  # configurations x error intervals counted while fitting (160 MB)
# a ridge parent's intervals hold at least this many training rows on average, so that each has a mode: fewer
# rows get wider intervals (FL_THERMAL probed every 30 min, 93 rows: 1.20 -> 1.05 x the ridge on ch5; the twins'
# held-out seeds 1.13 -> 0.99 and 1.01 -> 0.93; full rate unchanged)
ROWS_PER_INTERVAL = 30


def interval(values: np.ndarray, edges: list) -> np.ndarray:
    """Index of the interval of each value: the first interior edge it lies below, else the last."""
    index = np.full(len(values), len(edges), dtype=np.int64)
    for m in range(len(edges) - 1, -1, -1):
        index = np.where(values < edges[m], m, index)
    return index


def configuration(indices: list[np.ndarray], counts: list[int]) -> np.ndarray:
    """J = j_1 + K_1*(j_2 + K_2*(j_3 + ...)), the block's INT arithmetic."""
    j = indices[-1]
    for idx, k in zip(reversed(indices[:-1]), reversed(counts[:-1])):
        j = idx + k * j
    return j


UNSEEN_RULES = ("nearest", "frequent")
PARENTS = ("temperatures", "ridge")  # each temperature's rise (paper 004), or one: the ridge prediction from all


def _nearest_seen(rows_per_configuration: np.ndarray, counts: list[int]) -> np.ndarray:
    """For each configuration, the seen configuration the fewest interval steps away (ties: the one
    seen most often, then the lower index); in chunks, so 4096 x 4096 stays a few MB."""
    grid = np.array(np.unravel_index(np.arange(len(rows_per_configuration)), tuple(reversed(counts)))).T[:, ::-1]
    seen = np.nonzero(rows_per_configuration)[0]
    most = int(rows_per_configuration.max())
    tie = (most - rows_per_configuration[seen]).astype(np.int64)
    nearest = np.empty(len(grid), np.int64)
    for start in range(0, len(grid), 256):
        steps = np.abs(grid[start:start + 256, None, :] - grid[None, seen, :]).sum(axis=2).astype(np.int64)
        nearest[start:start + 256] = seen[np.argmin(steps * (most + 1) + tie[None, :], axis=1)]
    return nearest


def elapsed_s(rows: int, dt: float, f=np.float64) -> np.ndarray:
    """Seconds since the first call as the block counts them: 0, then + dt per call, in `f`."""
    steps = np.full(rows, f(dt), f)
    steps[0] = f(0.0)
    return np.add.accumulate(steps, dtype=f)


def fit_bayes(runs: list[tuple[np.ndarray, np.ndarray]], bins: int, precision_um: float, unseen: str = "nearest",
              time_bins: int = 0, dt: float = 1.0):
    """The network of one or more runs (temps, target), each run's rises taken from its first row as the
    block does. With `time_bins`, the time since the first call is a parent too (paper 004 fits one
    network per time instant over repeated runs; this is the form a block that runs continuously can
    compute)."""
    rises = [temps - temps[0] for temps, _ in runs]
    if time_bins:
        rises = [np.column_stack([r, elapsed_s(len(r), dt)]) for r in rises]
    measured = [np.isfinite(target) for _, target in runs]  # a probed target: its measured rows only
    bins_per_parent = [bins] * runs[0][0].shape[1] + ([time_bins] if time_bins else [])
    coefficients, settings, log = fit_rises(np.vstack([r[m] for r, m in zip(rises, measured)]),
                                            np.concatenate([t[m] for (_, t), m in zip(runs, measured)]),
                                            bins_per_parent, precision_um, unseen)
    settings["time_parent"] = bool(time_bins)
    return coefficients, settings, log


def fit_ridge_parent(parts: list[Part], names: list[str], precision_um: float, unseen: str = "nearest",
                     time_bins: int = 0, dt: float = 1.0):
    """The network on one temperature parent, the ridge prediction from every temperature's rise, and one
    child, what that prediction leaves of the error: the weights fitted as mlr fits its intercept and
    slopes, the parent in binary32 as the block computes it, in intervals `precision_um` wide (fewer where
    the training rows would leave fewer than ROWS_PER_INTERVAL an interval, or the block's table is full)."""
    if precision_um <= 0 or time_bins < 0:
        raise UserError("--time-bins must be at least 0 and --precision-um positive")
    beta, ridge_log = least_squares(*measured_rows(parts, lambda part: part.rises), names, measured_counts(parts))
    weights = [round_f32(w) for w in beta]
    values = [on_rises(list(part.temps.T), weights, np.float32).astype(float) for part in parts]
    residual = np.concatenate([p.target[p.measured] - v[p.measured] for v, p in zip(values, parts)])
    if time_bins:
        values = [np.column_stack([v, elapsed_s(len(v), dt)]) for v in values]
    values = np.vstack([np.reshape(v, (len(v), -1))[p.measured] for v, p in zip(values, parts)])
    span = float(values[:, 0].max() - values[:, 0].min())
    asked = max(1, math.ceil(span / precision_um))
    bounds = {f"{len(values)} training rows, at least {ROWS_PER_INTERVAL} an interval": len(values) // ROWS_PER_INTERVAL,
              f"{MAX_CONFIGURATIONS} configurations at most" + (f" with --time-bins {time_bins}" if time_bins else ""):
              MAX_CONFIGURATIONS // max(1, time_bins)}
    intervals = int(max(1, min(asked, *bounds.values())))
    coefficients, settings, log = fit_rises(values, residual, [intervals] + ([time_bins] if time_bins else []),
                                            precision_um, unseen, centred=True, advice="use a larger --precision-um")
    coefficients.update({f"w_{i}": Coefficient.of(w) for i, w in enumerate(weights)})
    settings.update(parents="ridge", time_parent=bool(time_bins))
    bound = (f" (--precision-um asked for {asked}; " + ", ".join(why for why, most in bounds.items() if most < asked)
             + ")") if intervals < asked else ""
    log = {**ridge_log, "method": f"one parent, the ridge prediction from every temperature's rise (weight by "
                                  f"{weight_by(ridge_log)}), in {counted(intervals, 'interval')} of "
                                  f"{span / intervals:.4g} um{bound}, plus what it leaves; {log['method']}"}
    return coefficients, settings, log


def counted(n: int, noun: str) -> str:
    """'1 interval', '8 intervals'."""
    return f"{n} {noun}" + ("" if n == 1 else "s")


def fit_rises(rises: np.ndarray, target: np.ndarray, bins: int | list[int], precision_um: float,
              unseen: str = "nearest", centred: bool = False, advice: str = "use a larger --precision-um or fewer --bins"):
    """The network on the parents' values (rows, parents): temperature rises, and the time since the
    first call when it is a parent; from any number of runs (paper 004 fits one per time instant).
    `centred`: an error interval has its midpoint at 0 (a residual's most probable interval is then 0
    where nothing is left, not half an interval off)."""
    bins = [bins] * rises.shape[1] if isinstance(bins, int) else bins
    if min(bins) < 1 or precision_um <= 0:
        raise UserError("--bins and --time-bins must be at least 1 and --precision-um positive")
    edges, counts = [], []
    for i in range(rises.shape[1]):
        low, high = float(rises[:, i].min()), float(rises[:, i].max())
        width = (high - low) / bins[i] if high > low else 1.0
        edges.append([low + m * width for m in range(1, bins[i])] if high > low else [])
        counts.append(len(edges[-1]) + 1)
    configurations = math.prod(counts)
    if configurations > MAX_CONFIGURATIONS:
        raise UserError(f"{configurations} temperature interval combinations exceed {MAX_CONFIGURATIONS}; "
                        f"use fewer --bins or fewer sensors")
    shift = 0.5 if centred else 0.0
    low = float((np.floor(target.min() / precision_um + shift) - shift) * precision_um)
    span = (float(target.max()) - low) / precision_um
    if not span < MAX_TABLE_CELLS / configurations:
        raise UserError(f"the error spans {float(target.max()) - low:.4g} um: intervals of --precision-um {precision_um:g} "
                        f"with {configurations} configurations of the parents' intervals exceed {MAX_TABLE_CELLS:,} "
                        f"table cells; {advice}")
    classes = max(1, int(np.ceil(span + 1e-9)))
    target_class = np.clip(((target - low) // precision_um).astype(np.int64), 0, classes - 1)
    j = configuration([interval(rises[:, i], edges[i]) for i in range(len(counts))], counts)
    table = np.zeros((configurations, classes))
    np.add.at(table, (j, target_class), 1.0)
    marginal = np.bincount(target_class, minlength=classes)
    posterior = (1.0 + table) / (classes + table.sum(axis=1, keepdims=True))
    best = np.lexsort((-marginal[None, :].repeat(configurations, 0), -posterior), axis=1)[:, 0]
    rows_per_configuration = table.sum(axis=1)
    if unseen == "nearest":
        best = best[_nearest_seen(rows_per_configuration, counts)]
    coefficients = {}
    for i, e in enumerate(edges, start=1):
        coefficients.update({f"edge_{i}_{m}": Coefficient.of(v) for m, v in enumerate(e)})
    coefficients.update({f"pred_{c}": Coefficient.of(low + (best[c] + 0.5) * precision_um)
                         for c in range(configurations)})
    seen = int(np.count_nonzero(rows_per_configuration))
    settings = {"intervals": counts, "error_low_um": low, "error_width_um": precision_um, "error_classes": classes,
                "configurations": configurations, "configurations_seen": seen, "unseen": unseen}
    return coefficients, settings, {"method": "Dirichlet N'=1 counts, most probable interval (paper 004 eq. 5-7)"}


def edges_of(model: Model, sensor: int, precision: str = "f32") -> list:
    """The interior interval edges of parent `sensor` (from 1; the time parent after the temperatures),
    ascending, at `precision`: one fewer than its interval count."""
    count = model.settings["intervals"][sensor - 1] - 1
    return [model.coef(f"edge_{sensor}_{m}", precision) for m in range(count)]


def predict_rises(coefficients: dict, settings: dict, rises: np.ndarray) -> np.ndarray:
    """float64 predictions of a fitted network (fit_rises' output) for rises (rows, sensors)."""
    counts = settings["intervals"]
    edges = [[coefficients[f"edge_{i}_{m}"].f64 for m in range(counts[i - 1] - 1)] for i in range(1, len(counts) + 1)]
    j = configuration([interval(rises[:, i], e) for i, e in enumerate(edges)], list(counts))
    return np.array([coefficients[f"pred_{c}"].f64 for c in range(settings["configurations"])])[j]


def predict(model: Model, inputs: dict, precision: str) -> dict:
    """Reference in binary32 ('f32') or float64, as the block reads it: each parent's interval, the configuration,
    that entry of the prediction table (added to the ridge parent, where it is one); returns {target name: error
    per row}."""
    f = np.float32 if precision == "f32" else np.float64
    temps = model.signals("temperature")
    ridge_parent = model.settings.get("parents") == "ridge"
    if ridge_parent:
        weights = [model.coef(f"w_{i}", precision) for i in range(len(temps) + 1)]
        rises = [on_rises([inputs[s.name] for s in temps], weights, f)]
    else:
        rises = [np.asarray(inputs[s.name], f) - np.asarray(inputs[s.name], f)[0] for s in temps]
    if model.settings.get("time_parent"):
        rises.append(elapsed_s(len(rises[0]), model.sample_period_s, f))
    indices = [interval(r, [f(e) for e in edges_of(model, i, precision)]) for i, r in enumerate(rises, start=1)]
    j = configuration(indices, list(model.settings["intervals"]))
    table = np.array([model.coef(f"pred_{c}", precision) for c in range(model.settings["configurations"])], f)
    return {model.target.name: rises[0] + table[j] if ridge_parent else table[j]}


def conflict(option: Callable[[str], Any], field: str) -> str | None:
    """Why an option bayes reads is refused beside the others given (`option(field)` reads them), or None."""
    if field == "bins" and option("parents") == "ridge":
        return ("--bins sets each temperature's intervals; with --parents ridge the one parent's intervals are "
                "--precision-um wide (fewer where training rows are few): leave --bins out")
    return None


def _fit(parts, request, names, dt, progress):
    if request.option("parents") == "ridge":
        return fit_ridge_parent(parts, names, request.option("precision_um"), request.option("unseen"),
                                request.option("time_bins"), dt)
    return fit_bayes([(p.temps, p.target) for p in parts], request.option("bins"), request.option("precision_um"),
                     request.option("unseen"), request.option("time_bins"), dt)


def check_settings(model: Model, path: str) -> None:
    """One interval count per parent, whose product is the number of configurations; a ridge parent's
    weight for every temperature."""
    s = model.settings
    temps = len(model.signals("temperature"))
    ridge_parent = s.get("parents") == "ridge"
    parents = (1 if ridge_parent else temps) + (1 if s.get("time_parent") else 0)
    if len(s["intervals"]) != parents or math.prod(s["intervals"]) != s["configurations"]:
        raise UserError(f"{path}: field 'settings': intervals {s['intervals']} and configurations "
                        f"{s['configurations']} do not fit {parents} parents (the product of the intervals is "
                        f"the number of configurations)")
    missing = [f"w_{i}" for i in range(temps + 1) if ridge_parent and f"w_{i}" not in model.coefficients]
    if missing:
        raise UserError(f"{path}: field 'coefficients': the ridge parent has no weight {', '.join(missing)} "
                        f"(w_0, the intercept, and one per temperature)")


SETTINGS_SCHEMA = {
    "type": "object",
    "required": ["intervals", "configurations"],
    "properties": {"intervals": {"type": "array", "minItems": 1, "maxItems": 65,
                                 "items": {"type": "integer", "minimum": 1, "maximum": 4096}},
                   "configurations": {"type": "integer", "minimum": 1, "maximum": 4096},
                   "configurations_seen": {"type": "integer", "minimum": 0},
                   "error_low_um": {"type": "number"},
                   "error_width_um": {"type": "number", "exclusiveMinimum": 0},
                   "error_classes": {"type": "integer", "minimum": 1},
                   "unseen": {"enum": list(UNSEEN_RULES)},
                   "parents": {"enum": list(PARENTS)},
                   "time_parent": {"type": "boolean"}}}

OPTIONS = (
    KindOption("bins", "--bins", 8, "intervals per temperature (default: %(default)s)", number=(int, 1, 4096, "intervals")),
    KindOption("precision_um", "--precision-um", 1.0, "interval width of the error, the precision requirement "
               "(default: %(default)s)", number=(float, 1e-3, 1e6, "micrometres")),
    KindOption("unseen", "--unseen", UNSEEN_RULES[0], "a temperature configuration never seen in training answers as "
               "the nearest seen one, or the error interval most frequent overall (default: %(default)s)",
               choices=UNSEEN_RULES),
    KindOption("time_bins", "--time-bins", 0, "the time since the first call is a parent too, in N intervals (paper "
               "004's repeated runs: give one --data file per run; default: %(default)s, no time parent)",
               number=(int, 0, 4096, "intervals"), metavar="N", owned="--time-bins is"),
    KindOption("parents", "--parents", PARENTS[0], "the network's temperature parents: each temperature's rise "
               "(paper 004), or one, the ridge prediction from every temperature's rise (intervals --precision-um "
               "wide, fewer where training rows are few; --bins not read), the block outputting it plus the most "
               "probable interval of what it leaves (many sensors; default: %(default)s)", choices=PARENTS,
               owned="--parents is"),
)
def structure(model: Model) -> dict:
    """The interval counts the configuration index multiplies by, and the seconds per call of a time parent."""
    counts = model.settings["intervals"]
    out = {f"k_{i}": counts[i - 1] for i in range(1, len(counts))}
    if model.settings.get("time_parent"):
        out["dt"] = round_f32(model.sample_period_s)
    return out


KIND = Kind("bayes", 7, "004", _fit, predict, options=OPTIONS, structure=structure,
            auto="closed-form", conflict=conflict, shrunk=(("parents", "ridge"),),
            settings_schema=SETTINGS_SCHEMA, check_settings=check_settings,
            streamable=lambda model: not model.settings.get("time_parent"))
