"""The grey models' estimates on a campaign, chosen leaving out each run (issue 62).

On one recording GM(0,N) and GM(1,N) are fitted the paper's way (models/kinds/grey.py). On several runs the
estimate is the one whose block output predicts each run best from the fit on the other runs, the measured
rows pooled, the run started where the block starts (the other runs' first errors on average):
- GM(0,N): the paper's fit on the 1-AGO sums, or a ridge on the error itself (the block's own form,
  b_0 + sum_i b_i*x_i(k), the unit sequence's b_0 shrunk with the rest), each with every ridge weight (least
  squares among them).
- GM(1,N): the paper's least-squares a and b (where a is in (0, 2), its time constant within the longest run
  and the sums resolvable in binary32), or each a of the grid with every ridge weight for b fitted to the grey
  equation or to the error the block outputs (the recursion is linear in b). The grid ends at a = 2, where the
  recursion keeps nothing (Keep = 0) and the block is the shrunk linear fit: a ridge on the sequences.
The shrunk linear fit (GM(0,N)'s ridge on the error, GM(1,N) at a = 2) is kept unless another candidate beats
it by more than one standard error of their paired difference over the runs: on FL_THERMAL ch3 cut into 6 h
runs (every sensor) GM(1,N)'s best candidate on seven runs (the grey equation at a time constant of 11 min)
beat it there by 5 % and missed the eighth run by 10.9 um where the shrunk fit misses it by 2.0.
The paper's fits weight each row by how far into its run it lies and fit an equation, not the output:
on FL_THERMAL cut into 6 h runs, four sensors chosen in each fold, GM(1,N) was 8.03 um held out on ch3
(a chosen inside each run) where a ridge on every sensor gives 3.58; now 4.78.
Each run's sums of products are formed once, so leaving out one run is a sum of the others' and a k x k
solve, not a refit on the stacked rows (a campaign of 40 runs would otherwise cost 40 refits per fit, and
cross-validation 40 fits).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thermoplc.base import ridge


@dataclass(frozen=True)
class Grams:
    """Per run: rows, column sums, X'X, X'y and X'o of a design X, a target y and an offset o the target
    moves by per unit of the block's start (zero where the start does not enter)."""
    rows: np.ndarray
    x: np.ndarray
    y: np.ndarray
    xx: np.ndarray
    xy: np.ndarray
    xo: np.ndarray

    @classmethod
    def of(cls, designs: list[np.ndarray], targets: list[np.ndarray], offsets: list[np.ndarray] | None = None):
        offsets = offsets or [np.zeros(len(t)) for t in targets]
        return cls(np.array([len(t) for t in targets], float), np.array([d.sum(axis=0) for d in designs]),
                   np.array([t.sum() for t in targets]), np.array([d.T @ d for d in designs]),
                   np.array([d.T @ t for d, t in zip(designs, targets)]),
                   np.array([d.T @ o for d, o in zip(designs, offsets)]))

    def slopes(self, members: np.ndarray, weights, intercept: bool, start: float = 0.0) -> list[tuple[float, np.ndarray]]:
        """(intercept, slopes) of a ridge on the runs `members` for every weight (base/ridge.from_sums), the target
        moved by -start * offset."""
        offsets, slopes = ridge.from_sums(self.rows[members].sum(), self.x[members].sum(axis=0), self.y[members].sum(),
                                          self.xx[members].sum(axis=0),
                                          self.xy[members].sum(axis=0) - start * self.xo[members].sum(axis=0),
                                          np.asarray(weights, float), intercept)
        return [(float(offsets[w]), slopes[:, w]) for w in range(len(weights))]


def label(estimate: str, weight: float) -> str:
    return f"{estimate}, {'least squares' if weight == 0.0 else f'ridge weight {weight:g}'}"


def choose(totals: dict[tuple, list[float]], runs: int, rows: int, acceptable, plain) -> tuple[tuple, float]:
    """The candidate with the least squared error over every left-out run that `acceptable` (its fit on every
    run) admits, and its held-out RMSE over the `rows` measured rows; but the best `plain` one (the shrunk linear
    fit) unless the other beats it by more than one standard error of their paired difference over the runs (the
    one-standard-error rule: among hundreds of candidates scored on a few runs, the best is partly chance)."""
    complete = sorted((sum(errors), key) for key, errors in totals.items() if len(errors) == runs)
    admitted = [(squared, key) for squared, key in complete if acceptable(key)]
    best = admitted[0]  # the ridge candidates are always acceptable
    shrunk = next((candidate for candidate in admitted if plain(candidate[1])), best)
    key = best[1] if ridge.beats(totals[best[1]], totals[shrunk[1]]) else shrunk[1]
    return key, float(np.sqrt(sum(totals[key]) / max(rows, 1)))


def gm0n(sums: list[np.ndarray], target_sums: list[np.ndarray], steps: list[np.ndarray], errors: list[np.ndarray]
         ) -> tuple[str, float, float]:
    """GM(0,N)'s estimate ('sums' or 'steps'), its ridge weight and held-out RMSE, from each run's running sums and
    their target, its steps and its errors (rows 2..n, NaN where not measured)."""
    measured = [np.isfinite(e) for e in errors]
    on_sums = Grams.of(sums, target_sums)
    on_steps = Grams.of([s[m] for s, m in zip(steps, measured)], [e[m] for e, m in zip(errors, measured)])
    weights = ridge.WEIGHTS if ridge.condition(np.vstack(sums), True) <= ridge.CONDITION_LIMIT else ridge.WEIGHTS[1:]
    totals: dict[tuple, list[float]] = {}
    for k in range(len(sums)):
        others = np.array([j for j in range(len(sums)) if j != k])
        for estimate, grams, intercept in (("sums", on_sums, True), ("steps", on_steps, False)):
            for weight, (_, b) in zip(weights, grams.slopes(others, weights, intercept)):
                residual = (errors[k] - steps[k] @ b)[measured[k]]
                totals.setdefault((estimate, weight), []).append(float(residual @ residual))
    (estimate, weight), rmse = choose(totals, len(sums), sum(int(m.sum()) for m in measured), lambda key: True,
                                      lambda key: key[0] == "steps")
    return estimate, weight, rmse


def gm1n(runs: list[tuple[np.ndarray, np.ndarray]], targets: list[np.ndarray], grid: list[float], pieces, paper,
         background, shrunk: float) -> tuple[str, float, float, float]:
    """GM(1,N)'s estimate ('paper', 'equation' or 'output'), its a, ridge weight and held-out RMSE; the output
    fitted with a = `shrunk` (no memory: the shrunk linear fit) is the plain candidate.
    `runs`: each run's running sums and filled target; `targets`: the measured target (NaN elsewhere);
    `pieces(sums, first, a)`: the block's output after its first call as design @ b + offset; `paper(runs)`:
    the paper's [a, b...] on some runs, or None where not admissible; `background(target)`: z1(k)."""
    measured = [np.isfinite(t[1:]) for t in targets]
    firsts = np.array([target[0] for _, target in runs])
    count = len(runs)
    leave = [np.array([j for j in range(count) if j != k]) for k in range(count)]
    starts = [float(firsts[others].mean()) for others in leave]
    totals: dict[tuple, list[float]] = {}

    def score(key: tuple, k: int, a: float, b: np.ndarray, design: np.ndarray | None = None, offset=None) -> None:
        if design is None:
            design, offset = pieces(runs[k][0], starts[k], a)
        residual = (targets[k][1:] - design @ b - offset)[measured[k]]
        totals.setdefault(key, []).append(float(residual @ residual))

    for k, others in enumerate(leave):
        params = paper([runs[j] for j in others])
        if params is not None:
            score(("paper", 0.0, 0.0), k, float(params[0]), params[1:])
    on_sums = [sums[1:] for sums, _ in runs]
    # the equation's target x1(k) + a*z1(k): X'x1 - a*X'(-z1), the offset carrying -z1 and "start" a
    equation = Grams.of(on_sums, [target[1:] for _, target in runs], [-background(target) for _, target in runs])
    for a in grid:
        unit = [pieces(sums, 1.0, a) for sums, _ in runs]  # the start enters the output linearly: offset x start
        zero = [design for design, _ in unit]
        output = Grams.of([d[m] for d, m in zip(zero, measured)], [t[1:][m] for t, m in zip(targets, measured)],
                          [o[m] for (_, o), m in zip(unit, measured)])
        for k, others in enumerate(leave):
            for weight, (_, b) in zip(ridge.WEIGHTS, equation.slopes(others, ridge.WEIGHTS, False, a)):
                score(("equation", a, weight), k, a, b, zero[k], starts[k] * unit[k][1])
            for weight, (_, b) in zip(ridge.WEIGHTS, output.slopes(others, ridge.WEIGHTS, False, starts[k])):
                score(("output", a, weight), k, a, b, zero[k], starts[k] * unit[k][1])
    (estimate, a, weight), rmse = choose(totals, count, sum(int(m.sum()) for m in measured),
                                         lambda key: key[0] != "paper" or paper(runs) is not None,
                                         lambda key: key[0] == "output" and key[1] == shrunk)
    return estimate, a, weight, rmse

