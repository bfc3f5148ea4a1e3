"""The static part refitted for what the probings cannot see: the change since the last probing.

A fused block outputs the static prediction plus the offset the last probing left, so between probings its
error is the target's change since that probing minus the static part's change over the same calls. A fit on
the levels spends its slopes on the slow drift the probings already remove; a fit on the increments spends them
on the change within a probing interval. For a kind whose prediction is linear in columns of its inputs
(`Kind.increments`), the slopes are refitted by ridge least squares on the increments between each measured row
and the probing before it: on a target measured at every call every phase of an N-call schedule (lags 1..N-1),
on a probed target its consecutive probings. The intercept is the level fit's mean residual (it counts only
before the first probing). The ridge weight is chosen leaving one run out (one recording: one of four blocks of
its training part) on the same increments; everything works on the increments' sums of products, so the pairs
are never stored.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thermoplc.models.kind import Part
from thermoplc.base.ridge import WEIGHTS

BLOCKS = 4  # one recording's training part is cut into this many blocks to choose the ridge weight


@dataclass(frozen=True)
class Sums:
    """Sums of products of the increments of one segment: enough for every ridge fit and its error."""
    gram: np.ndarray  # columns' increments, (k, k)
    cross: np.ndarray  # columns' increments times the target's, (k,)
    target: float  # the target's increments squared
    pairs: int

    def __add__(self, other: "Sums") -> "Sums":
        return Sums(self.gram + other.gram, self.cross + other.cross, self.target + other.target,
                    self.pairs + other.pairs)

    def error(self, slopes: np.ndarray) -> float:
        """Sum of squared increment errors of `slopes` on these pairs."""
        return float(self.target - 2 * slopes @ self.cross + slopes @ self.gram @ slopes)


def sums(columns: np.ndarray, target: np.ndarray, every: int | None) -> Sums:
    """The increments' sums of one run: every lag 1..every-1 of a target measured at every call, or consecutive
    measured rows of a probed target (`every` None)."""
    k = columns.shape[1]
    total = Sums(np.zeros((k, k)), np.zeros(k), 0.0, 0)
    if every is None:
        rows = np.flatnonzero(np.isfinite(target))
        dx, dy = np.diff(columns[rows], axis=0), np.diff(target[rows])
        return Sums(dx.T @ dx, dx.T @ dy, float(dy @ dy), len(dy))
    for lag in range(1, min(every, len(target))):
        dx, dy = columns[lag:] - columns[:-lag], target[lag:] - target[:-lag]
        total = total + Sums(dx.T @ dx, dx.T @ dy, float(dy @ dy), len(dy))
    return total


def _ridge(total: Sums, weight: float) -> np.ndarray:
    """Slopes of the ridge fit on standardised increments (no intercept: it cancels in an increment)."""
    scale = np.sqrt(np.maximum(np.diag(total.gram) / max(total.pairs, 1), 1e-300))
    z = total.gram / np.outer(scale, scale) + weight * total.pairs * np.eye(len(scale))
    return np.linalg.lstsq(z, total.cross / scale, rcond=None)[0] / scale


def choose_weight(segments: list[Sums]) -> float:
    """The ridge weight with the lowest error on each segment left out in turn (least squares on a tie)."""
    everything = sum(segments[1:], segments[0])
    scored = []
    for weight in WEIGHTS:
        error = sum(s.error(_ridge(everything + Sums(-s.gram, -s.cross, -s.target, -s.pairs), weight))
                    for s in segments)
        scored.append((error, weight))
    return min(scored)[1]


@dataclass(frozen=True)
class Refit:
    """The refitted coefficients and how they were chosen, for the model file's fit log."""
    coefficients: dict[str, float]
    weight: float
    pairs: int


def refit(kind, settings: dict, parts: list[Part], every: int | None) -> Refit | None:
    """The kind's slopes refitted on the increments of `parts` (one per run), or None where the increments
    cannot be fitted (no pair, or a column that never moves between probings)."""
    designs = [np.asarray(kind.increments.columns(p, settings), float) for p in parts]
    pieces = _blocks(designs[0], parts[0].target) if len(parts) == 1 else zip(designs, (p.target for p in parts))
    segments = [s for s in (sums(x, y, every) for x, y in pieces) if s.pairs]
    if len(segments) < 2:
        return None
    everything = sum(segments[1:], segments[0])
    if np.any(np.diag(everything.gram) <= 0.0):
        return None
    weight = choose_weight(segments)
    slopes = _ridge(everything, weight)
    residual = np.concatenate([(p.target - x @ slopes)[p.measured] for x, p in zip(designs, parts)])
    names = kind.increments.slopes(settings, parts[0].temps.shape[1])
    return Refit({"beta0": float(np.mean(residual)), **dict(zip(names, map(float, slopes)))}, weight,
                 sum(s.pairs for s in segments))


def _blocks(design: np.ndarray, target: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """One recording's training part as BLOCKS contiguous blocks (the columns keep the run's own start)."""
    bounds = np.linspace(0, len(target), BLOCKS + 1).astype(int)
    return [(design[a:b], target[a:b]) for a, b in zip(bounds, bounds[1:])]


def trained_calls(model) -> int:
    """The calls of one recording's training part (a probed target counts fewer measured rows than calls)."""
    train = model.metrics["train"]
    return int(train.get("calls", train["rows"]))


def parts_of(model, tables: list, calls: list[int]) -> list[Part]:
    """Each run's first `calls` calls as a kind's fitter takes them (the temperatures as the fit read them)."""
    temps = [s.column for s in model.signals("temperature")]
    return [Part(np.column_stack([t.columns[c] for c in temps])[:n], t.columns[model.target.column][:n],
                 np.empty((n, 0)), None, None) for t, n in zip(tables, calls)]


@dataclass(frozen=True)
class Refitted:
    """The model with refitted slopes, its metrics in the static fit's form (held out fold by fold alike), and each
    run's held-out static prediction (by run path) for the fusion to be chosen on."""
    model: object
    predictions: dict


def refitted(model, tables: list, every: int | None) -> Refitted | None:
    """`model`'s slopes refitted on the increments, judged as the static fit was: one recording's held-out part, or
    each fold of a campaign refitted without its runs. None for a kind that is not linear in its columns or where
    the increments cannot be fitted."""
    from thermoplc.models.kinds import kind_of
    kind = kind_of(model.kind)
    if kind.increments is None:
        return None
    if "runs" not in model.metrics:
        trained = trained_calls(model)
        found = _with(model, kind, parts_of(model, tables, [trained]), every)
        return found and Refitted(_evaluated(found, tables, [trained]), {})
    final = _with(model, kind, parts_of(model, tables, [t.rows for t in tables]), every)
    return final and _cross_validated(final, kind, tables, every)


def _with(model, kind, parts: list[Part], every: int | None):
    """`model` with its slopes refitted on `parts`, or None."""
    from dataclasses import replace
    from thermoplc.models.model import Coefficient
    found = refit(kind, model.settings, parts, every)
    if found is None:
        return None
    log = {"method": "slopes refitted by ridge least squares on the change between each measured row and the probing "
                     "before it", "ridge_weight": found.weight, "increment_pairs": found.pairs}
    return replace(model, coefficients={**model.coefficients, **{k: Coefficient.of(v) for k, v in found.coefficients.items()}},
                   fit={**model.fit, "probe_refit": log})


def _evaluated(model, tables: list, calls: list[int]):
    from dataclasses import replace
    from thermoplc.fitting.fit import evaluate, restarted
    model = restarted(model, tables, calls)  # the static fit's start and envelope are stale for the new slopes
    return replace(model, metrics={**model.metrics, **evaluate(model, tables, calls)})


def _cross_validated(final, kind, tables: list, every: int | None) -> Refitted | None:
    """The campaign's folds (as the static fit cut them) each refitted without its runs: its held-out errors and
    predictions, pooled in the model file's form."""
    from dataclasses import replace
    from thermoplc.recordings.campaign import run_labels
    from thermoplc.fitting.crossval import judge_fold, pooled
    from thermoplc.fitting.fit import evaluate, restarted
    final = restarted(final, tables, [t.rows for t in tables])
    labels = run_labels([t.path for t in tables])
    folds: dict[str, list[int]] = {}
    for entry in final.metrics["runs"]:
        folds.setdefault(entry["fold"], []).append(labels.index(entry["run"]))
    judged = []
    for label, members in folds.items():
        others = [tables[k] for k in range(len(tables)) if k not in members]
        model = _with(final, kind, parts_of(final, others, [t.rows for t in others]), every)
        if model is None:
            return None
        trained = sum(int(np.count_nonzero(np.isfinite(t.columns[final.target.column]))) for t in others)
        judged.append(judge_fold(model, tables, members, label, trained, True))
    whole = evaluate(final, tables, [t.rows for t in tables])
    protocol = f"{final.metrics['held_out']['protocol']}, each fold's slopes refitted for the change since the last probing"
    metrics = {**final.metrics, "train": whole["train"], "float32_vs_float64_max_um": whole["float32_vs_float64_max_um"],
               "held_out": {**pooled([j.fold for j in judged]), "protocol": protocol},
               "cross_validation": [j.fold.as_dict() for j in judged], "runs": [r for j in judged for r in j.per_run]}
    return Refitted(replace(final, metrics=metrics), {path: p for j in judged for path, p in j.predictions})
