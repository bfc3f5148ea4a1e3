"""The floating-point genetic algorithms of paper 000 §3.4 and paper 002.

Both: roulette selection (fitness 1/objective: smaller objective, larger share), pairs crossed
with probability p_c. Paper 000 (`operators="paper000"`, the Kalman fit): arithmetic crossover
(eq. 14), Gaussian mutation (eq. 15) with probability p_m per gene, re-drawn when it leaves the
bounds. Paper 002 (`operators="paper002"`, GA-BP): single-point crossover (the codes after a
random cut are exchanged), and each individual mutates with probability p_m at one random
position, re-drawn uniformly within its bounds. The best individual so far is carried into each
generation (elitism), so the result never gets worse from one generation to the next.
"""
from __future__ import annotations

import time

from dataclasses import dataclass
from typing import Callable

import numpy as np

from thermoplc.models.kind import KindOption

REDRAW_LIMIT = 50
# the options of a fit by GA or DE, read by kalman and bpnn alike
GA_OPTIONS = (
    KindOption("seed", "--seed", 0, "random seed of the optimiser (default: %(default)s)", number=(int, 0, 2 ** 32 - 1, "a seed")),
    KindOption("generations", "--generations", 60, "generations of the GA or DE (default: %(default)s)",
               number=(int, 1, 10000, "generations")),
    KindOption("population", "--population", 40, "individuals per generation (default: %(default)s)",
               number=(int, 2, 10000, "individuals")),
)


@dataclass(frozen=True)
class GaResult:
    x: np.ndarray
    cost: float
    history: tuple[float, ...]  # best cost after each generation
    evaluations: int


def genetic_minimize(
    objective: Callable[[np.ndarray], np.ndarray],
    lower: np.ndarray,
    upper: np.ndarray,
    rng: np.random.Generator,
    population: int = 40,
    generations: int = 60,
    p_crossover: float = 0.7,
    p_mutation: float = 0.02,
    mutation_scale: float = 0.1,
    progress: Callable[[int, float], None] | None = None,
    operators: str = "paper000",
) -> GaResult:
    """Minimise `objective`, which maps a (population, genes) array to (population,) costs."""
    crossover, mutate = OPERATORS[operators]
    lower = np.asarray(lower, float)
    upper = np.asarray(upper, float)
    span = upper - lower
    pop = lower + rng.random((population, len(lower))) * span
    cost = _evaluate(objective, pop)
    best = int(np.argmin(cost))
    best_x, best_cost = pop[best].copy(), float(cost[best])
    history = []
    for generation in range(generations):
        parents = pop[_roulette(cost, rng, population)]
        children = parents.copy()
        for i in range(0, population - 1, 2):
            if rng.random() < p_crossover:
                children[i], children[i + 1] = crossover(parents[i], parents[i + 1], rng)
        mutate(children, lower, upper, span * mutation_scale, p_mutation, rng)
        cost = _evaluate(objective, children)
        worst = int(np.argmax(cost))
        children[worst], cost[worst] = best_x, best_cost
        pop = children
        best = int(np.argmin(cost))
        if cost[best] < best_cost:
            best_x, best_cost = pop[best].copy(), float(cost[best])
        history.append(best_cost)
        if progress:
            progress(generation + 1, best_cost)
    return GaResult(best_x, best_cost, tuple(history), population * (generations + 1))


def _evaluate(objective, pop: np.ndarray) -> np.ndarray:
    cost = np.asarray(objective(pop), float)
    return np.where(np.isfinite(cost), cost, np.inf)


def _roulette(cost: np.ndarray, rng: np.random.Generator, count: int) -> np.ndarray:
    finite = np.isfinite(cost)
    if not finite.any():
        return rng.integers(0, len(cost), count)
    fitness = np.zeros(len(cost))
    fitness[finite] = 1.0 / (cost[finite] + 1e-300)
    return rng.choice(len(cost), size=count, p=fitness / fitness.sum())


def _arithmetic_crossover(a: np.ndarray, b: np.ndarray, rng: np.random.Generator):
    sigma = rng.random()
    return sigma * a + (1 - sigma) * b, (1 - sigma) * a + sigma * b


def _single_point_crossover(a: np.ndarray, b: np.ndarray, rng: np.random.Generator):
    if len(a) < 2:
        return a.copy(), b.copy()
    cut = int(rng.integers(1, len(a)))
    return np.concatenate([a[:cut], b[cut:]]), np.concatenate([b[:cut], a[cut:]])


def _one_position_mutation(pop, lower, upper, scale, p_mutation, rng) -> None:
    for i in np.nonzero(rng.random(len(pop)) < p_mutation)[0]:
        k = int(rng.integers(0, pop.shape[1]))
        pop[i, k] = lower[k] + rng.random() * (upper[k] - lower[k])


def _gaussian_mutation(pop, lower, upper, scale, p_mutation, rng) -> None:
    for i, k in zip(*np.nonzero(rng.random(pop.shape) < p_mutation)):
        for _ in range(REDRAW_LIMIT):
            candidate = pop[i, k] + scale[k] * rng.standard_normal()
            if lower[k] <= candidate <= upper[k]:
                pop[i, k] = candidate
                break


OPERATORS = {"paper000": (_arithmetic_crossover, _gaussian_mutation),
             "paper002": (_single_point_crossover, _one_position_mutation)}


def step_reporter(step: str, steps: int, progress: Callable[[str], None] | None, unit: str = "generation",
                  cost: str = "best RMS") -> Callable[[int, float], None] | None:
    """Progress of one step of a long fit with an estimate of the time it has left, from the time per
    generation (or epoch) so far; None without progress."""
    if not progress:
        return None
    started = time.perf_counter()

    def report(done: int, value: float) -> None:
        left = (time.perf_counter() - started) / max(done, 1) * max(steps - done, 0)
        progress(f"{step}: {unit} {done}/{steps}, {cost} {value:.4g}, about {left:.0f} s left")
    return report
