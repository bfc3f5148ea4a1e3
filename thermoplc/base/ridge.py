"""Linear maps that do not extrapolate: ridge least squares with the weight chosen by forward validation.

Temperatures on one machine move together, so plain least squares on them returns large slopes of
opposite sign that fit the training rows and cancel badly on rows it did not see (FL_THERMAL ch5:
MLR on all 16 sensors 16.5 um held out, against 6.1 um on four). Every linear map of the fitted
kinds goes through `fit_linear`: the columns are standardised, the slopes shrunk by a weight per
row (the intercept is not shrunk), and the weight is the one that predicts best on rows it did not
see. One recording: forward - fitted on the first two thirds of the training rows, scored on the
last third, as the block would run after commissioning. Several runs (a campaign): each run
predicted by the fit on the others, the runs pooled - the last third of pooled runs would be the
last runs only, one season of the hall, and chose a weight that suits them (the lathe campaign of
issue 50). Weight 0 (least squares) is among the candidates unless the columns are too collinear
for binary32 to resolve the slopes.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from thermoplc.base.errors import UserError

WEIGHTS = (0.0, *10.0 ** np.arange(-6.0, 0.5, 0.5))  # per row, on standardised columns
FIT_SHARE = 2 / 3  # forward validation: fitted on this share of the training rows, scored on the rest
MIN_VALIDATION_ROWS = 12
# Above this condition number of the standardised columns, binary32 (about 7 digits) cannot
# resolve least-squares slopes: they come out large, of opposite sign, and cancel in the block.
CONDITION_LIMIT = 1e6


@dataclass(frozen=True)
class LinearFit:
    """Intercept and slopes on the raw columns, and how the shrinkage was chosen."""
    intercept: float
    slopes: np.ndarray
    weight: float
    validation_rmse: float | None  # of the chosen weight on the rows it did not see; None when too few rows
    runs_left_out: int = 0  # the weight chosen leaving out each of these runs; 0: forward validation

    def log(self) -> dict:
        chosen = {"ridge_weight_by": f"leaving out each of {self.runs_left_out} runs"} if self.runs_left_out else {}
        return {"ridge_weight": self.weight, "ridge_validation_rmse": self.validation_rmse, **chosen}


def refuse_flat(features: np.ndarray, names: list[str]) -> None:
    """A column that does not move on the training rows has no slope to fit: refuse it by name."""
    spread = (features - features.mean(axis=0)).std(axis=0)
    flat = [names[i] for i in np.nonzero(spread <= 1e-12 * np.maximum(np.abs(features).max(axis=0), 1.0))[0]]
    if flat:
        raise UserError(f"{', '.join(flat)} does not change on the training rows: its slope cannot be fitted; "
                        f"drop it or train on data where it moves")


def _standardised(design: np.ndarray, intercept: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Columns centred (when there is an intercept) and scaled to unit RMS; the mean and scale used."""
    mean = design.mean(axis=0) if intercept else np.zeros(design.shape[1])
    spread = np.sqrt(np.mean((design - mean) ** 2, axis=0))
    spread[spread == 0.0] = 1.0
    return (design - mean) / spread, mean, spread


def ridge(design: np.ndarray, y: np.ndarray, weight: float, intercept: bool = True) -> tuple[float, np.ndarray]:
    """Intercept and slopes of a ridge fit on standardised columns (the intercept not shrunk)."""
    z, mean, spread = _standardised(design, intercept)
    offset = float(y.mean()) if intercept else 0.0
    k = z.shape[1]
    # the penalty as rows under the design: least squares on that stack is the ridge solution, and
    # with weight 0 on two identical columns it is the minimum-norm one instead of a singular solve
    stacked = np.vstack([z, np.sqrt(weight * len(y)) * np.eye(k)])
    slopes = np.linalg.lstsq(stacked, np.r_[y - offset, np.zeros(k)], rcond=None)[0] / spread
    return offset - float(mean @ slopes), slopes


def condition(design: np.ndarray, intercept: bool) -> float:
    """Condition number of the standardised columns: above CONDITION_LIMIT binary32 cannot resolve
    their least-squares slopes."""
    if design.shape[1] < 2:
        return 1.0
    singular = np.linalg.svd(_standardised(design, intercept)[0], compute_uv=False)
    return float(singular[0] / max(singular[-1], 1e-300))


def fit_linear(features: np.ndarray, target: np.ndarray, names: list[str], intercept: bool = True,
               output_error: Callable[[float, np.ndarray, slice], np.ndarray] | None = None,
               weights: tuple[float, ...] = WEIGHTS, runs: Sequence[int] | None = None) -> LinearFit:
    """Ridge fit of `target` on `features`, the weight chosen by forward validation, or by leaving out
    each run when `runs` (the row counts of the runs stacked in the rows, in order) holds two or more.

    `output_error(intercept, slopes, rows)` is the error of what the block outputs on `rows` when
    that differs from the fitted target (GM(0,N) fits running sums and outputs their steps); by
    default the residual of the fit itself. `weights=(0.0,)` asks for least squares, which columns
    too collinear for binary32 still do not get: they take the shrinkage that validates best."""
    features = np.asarray(features, float).reshape(len(target), -1)
    refuse_flat(features, names)
    if output_error is None:
        output_error = lambda offset, slopes, rows: target[rows] - offset - features[rows] @ slopes
    if condition(features, intercept) > CONDITION_LIMIT:
        weights = tuple(w for w in weights if w > 0.0) or WEIGHTS[1:]
    if runs is not None and len(runs) >= 2 and intercept and len(weights) > 1:
        if sum(runs) != len(target) or min(runs) < 1:
            raise ValueError(f"runs {list(runs)} do not cover the {len(target)} rows")
        rmse, weight = min(zip(leave_one_run_out(features, target, runs, weights), weights))
        offset, slopes = ridge(features, target, weight, intercept)
        return LinearFit(offset, slopes, float(weight), rmse, len(runs))
    cut = validation_cut(len(target))
    if cut is None:
        weight, rmse = weights[0], None  # too short to validate: least squares (or the least shrinkage)
    else:
        scored = []
        for candidate in weights:
            offset, slopes = ridge(features[:cut], target[:cut], candidate, intercept)
            scored.append((rms(output_error(offset, slopes, slice(cut, None))), candidate))
        rmse, weight = min(scored)
    offset, slopes = ridge(features, target, weight, intercept)
    return LinearFit(offset, slopes, float(weight), rmse)


@dataclass(frozen=True)
class RunSums:
    """Each run's sums of products of the columns and the target, centred on their overall means (so the sums
    keep their digits): rows, column sums, X'X, X'y, y'y. Any subset of the columns is scored from them."""
    rows: np.ndarray  # (runs,)
    x: np.ndarray  # (runs, k)
    y: np.ndarray  # (runs,)
    xx: np.ndarray  # (runs, k, k)
    xy: np.ndarray  # (runs, k)
    yy: np.ndarray  # (runs,)

    @classmethod
    def of(cls, design: np.ndarray, y: np.ndarray, runs: Sequence[int]) -> "RunSums":
        x = design - design.mean(axis=0)
        t = y - y.mean()
        bounds = np.cumsum([0, *runs])
        pieces = [(x[a:b], t[a:b]) for a, b in zip(bounds[:-1], bounds[1:])]
        return cls(np.array(runs, float), np.array([p.sum(axis=0) for p, _ in pieces]),
                   np.array([q.sum() for _, q in pieces]), np.array([p.T @ p for p, _ in pieces]),
                   np.array([p.T @ q for p, q in pieces]), np.array([q @ q for _, q in pieces]))


def leave_one_run_out(design: np.ndarray, y: np.ndarray, runs: Sequence[int], weights: Sequence[float]) -> list[float]:
    """Pooled RMSE of each weight when each run is predicted by the ridge fitted on the others."""
    sums = RunSums.of(design, y, runs)
    return run_errors(sums, list(range(design.shape[1])), weights)


def from_sums(n: float, sx: np.ndarray, sy: float, sxx: np.ndarray, sxy: np.ndarray, weights: np.ndarray,
              intercept: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Intercepts (weights,) and slopes (k, weights) of the ridge `ridge` fits, from the rows' count, column sums,
    target sum, X'X and X'y alone (a run left out is the totals less its own): standardised columns, the intercept
    not shrunk; weight 0 drops the directions binary32 cannot resolve."""
    mx, my = (sx / n, sy / n) if intercept else (np.zeros(len(sxy)), 0.0)
    centred = sxx - n * np.outer(mx, mx)
    spread = np.sqrt(np.maximum(np.diag(centred), 0.0) / n)
    spread[spread == 0.0] = 1.0
    values, vectors = np.linalg.eigh(centred / np.outer(spread, spread))
    projected = vectors.T @ ((sxy - n * mx * my) / spread)
    kept = values > max(values.max(), 0.0) / CONDITION_LIMIT ** 2  # beyond it weight 0 is no candidate
    denominator = values[:, None] + weights[None, :] * n
    gain = np.where(kept[:, None] | (weights[None, :] > 0), 1.0 / np.where(denominator > 0, denominator, 1.0), 0.0)
    slopes = (vectors @ (gain * projected[:, None])) / spread[:, None]
    return my - mx @ slopes, slopes


def run_errors(sums: RunSums, columns: Sequence[int], weights: Sequence[float],
               held: Sequence[int] | None = None) -> list[float]:
    """`leave_one_run_out` on `columns` of the sums, scoring the runs `held` (default: every run): a fold's fit
    is the totals less the run left out, and the run's squared error follows from its own sums, so forty
    runs cost forty small eigendecompositions, not forty fits on the rows."""
    c = np.asarray(columns)
    x, xx, xy = sums.x[:, c], sums.xx[:, c][:, :, c], sums.xy[:, c]
    weights = np.asarray(weights, float)
    total = (sums.rows.sum(), x.sum(axis=0), sums.y.sum(), xx.sum(axis=0), xy.sum(axis=0))
    squares = np.zeros(len(weights))
    held = range(len(sums.rows)) if held is None else held
    for r in held:
        offset, slopes = from_sums(*(t - v for t, v in zip(total, (sums.rows[r], x[r], sums.y[r], xx[r], xy[r]))),
                                   weights)
        squares += (sums.yy[r] - 2 * offset * sums.y[r] - 2 * xy[r] @ slopes + sums.rows[r] * offset ** 2
                    + 2 * offset * (x[r] @ slopes) + np.einsum("kw,kj,jw->w", slopes, xx[r], slopes))
    return [float(np.sqrt(max(v, 0.0) / sums.rows[list(held)].sum())) for v in squares]


def beats(errors: Sequence[float], plain: Sequence[float]) -> bool:
    """Whether per-run squared errors `errors` are lower than `plain`'s by more than one standard error of their
    paired difference over the runs (the one-standard-error rule: a candidate chosen among many on a few runs
    is partly chance, so the shrunk or plain one is kept unless the runs say clearly otherwise)."""
    difference = np.subtract(errors, plain)
    return len(difference) > 1 and difference.sum() + np.sqrt(len(difference)) * difference.std(ddof=1) < 0


def validation_cut(rows: int) -> int | None:
    """First row of the forward-validation part, or None when either part would be too short."""
    cut = int(round(FIT_SHARE * rows))
    return None if rows - cut < MIN_VALIDATION_ROWS or cut < MIN_VALIDATION_ROWS else cut


def rms(residual: np.ndarray) -> float:
    return float(np.sqrt(np.mean(residual ** 2)))



def nested_run_errors(sums: RunSums, columns: Sequence[int], weights: Sequence[float] = WEIGHTS) -> list[float]:
    """Each run's sum of squared errors when the fit on the other runs predicts it, the ridge weight chosen by
    leaving out each of those others in turn (from three runs; with two, the weight best on both): the paired
    figures `beats` compares. The best weight's own leave-one-run-out error is optimistic, and the more so the
    more columns it shrinks (FL_THERMAL ch3, 7 runs: dlag's 60 lagged columns 3.57 um by it, 4.04 nested, where
    the current rises' 16 give 3.95 and 4.03; the run left out: 6.62 and 4.69)."""
    count = len(sums.rows)
    errors = []
    for r in range(count):
        others = [q for q in range(count) if q != r]
        inner = RunSums(*(part[others] for part in (sums.rows, sums.x, sums.y, sums.xx, sums.xy, sums.yy)))
        scored = run_errors(inner, columns, weights) if count >= 3 else run_errors(sums, columns, weights)
        weight = weights[int(np.argmin(scored))]
        errors.append(run_errors(sums, columns, [weight], [r])[0] ** 2 * sums.rows[r])
    return errors
