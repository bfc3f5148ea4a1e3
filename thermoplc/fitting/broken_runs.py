"""Runs a campaign's fit must not train on (issue 62, item 2): a run whose sensors disagree with the other runs'.

One broken channel in one run (a jump, a dead or swapped connector, a sensor working loose) spoils every kind:
on the lathe campaign of issue 62 one sensor of one run rose 38 K with a 6.5 K jump where the other runs stayed
within 10.6 K, and an mlr held-out on that run was 326 um off; fitted with it, every other run got worse. With
the run's temperatures x (the model's, and its ambient), per campaign of MIN_RUNS runs or more:

1. the sensors: per temperature, its least-squares relation on the others (absolute readings with intercept, as
   the block's plausibility check has it, models/plausibility.py) fitted on the other runs, and the gate the
   block would get from them (MARGIN x their largest |difference|, at least GATE_FLOOR_K). A run whose
   difference exceeds that gate is one the block fitted without it would flag (`SensorsDisagree`).
2. the target: the run's error when a ridge on every temperature's rise (base/ridge.py, its weight chosen
   leaving runs out) fitted on the other runs predicts it, against the median of the other runs' errors, each
   predicted the same way in the campaign without the run. At least RATIO times: the model cannot carry it. Or
   the other runs predicted INFLUENCE times worse with it among them than without it: it bends their fit.

A run that fails both is refused: its temperatures do not relate as in the other runs (a broken sensor, or an
effect the other runs did not have: the block fitted without it flags such a run and holds), the fit and every
fold train without it, and its prediction by the written
model (which never saw it) is reported apart, and pooled into a held-out figure "with" it. A run whose
sensors disagree but whose target does not mind is named and kept; a run only hard to predict (another programme,
a cold hall) is neither. Worst first, one at a time, the others judged again without
it (a broken run bends the relations the others are judged by), at most a third of the runs.

Measured (benchmarks/broken_runs.py): no run refused or named on FL_THERMAL cut into 3 h and 6 h runs (ch3 on two
sensors, ch5 on four and fifteen) or on twin campaigns of both machines (seeds 1-3). With one run's first sensor
broken, the sound runs' held-out error is at most 1.14 x that of the campaign without the broken run (a dead
channel on fifteen sensors, named, kept); the 6.5 K jump is refused in 7 of 12 campaigns and costs at most 1 % where
it is kept; training on every run costs up to 2.1 x. `fit --keep-every-run` trains on every run whatever the rule says.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from thermoplc.base import ridge
from thermoplc.models.plausibility import GATE_FLOOR_K, MARGIN
from thermoplc.recordings.campaign import run_labels
from thermoplc.recordings.table import Table

MIN_RUNS = 4  # the run judged against the median of at least three others
RATIO = 2.0  # clean campaigns reached 3.2 on the target alone, never with a sensor beyond its gate as well
INFLUENCE = 1.1  # the other runs predicted 10 % worse with the run among them: the run bends their fit (a swapped
# connector on the twin's cascade: the run itself 1.4 x the others' median, the others 38 % worse with it)
MAX_SHARE = 1 / 3  # a campaign where more runs disagree is not a campaign with a broken run


@dataclass(frozen=True)
class JudgedRun:
    """One run as the rule saw it: the sensor furthest beyond its gate (by share of the gate), and the target's
    held-out error beside the other runs' median."""
    index: int
    run: str
    sensor: str
    difference_K: float
    gate_K: float
    error_um: float
    others_median_um: float
    influence: float = 1.0  # the other runs' pooled held-out error with this run among them over without it

    @property
    def sensors_disagree(self) -> bool:
        return self.difference_K > self.gate_K

    @property
    def ratio(self) -> float:
        return self.error_um / self.others_median_um if self.others_median_um > 0 else float("inf")

    @property
    def target_off(self) -> bool:
        return self.ratio >= RATIO or self.influence >= INFLUENCE

    def as_dict(self) -> dict:
        return {"run": self.run, "sensor": self.sensor, "difference_K": round(self.difference_K, 4),
                "gate_K": round(self.gate_K, 4), "ridge_error_um": round(self.error_um, 4),
                "others_median_um": round(self.others_median_um, 4), "ratio": round(self.ratio, 3),
                "influence": round(self.influence, 3)}


@dataclass(frozen=True)
class Screening:
    refused: tuple[JudgedRun, ...] = ()
    named: tuple[JudgedRun, ...] = ()  # kept: their sensors disagree, their target does not mind

    @property
    def refused_indices(self) -> tuple[int, ...]:
        return tuple(sorted(r.index for r in self.refused))

    def log(self) -> dict:
        return {"rule": f"refused when a temperature is beyond the gate the other runs give ({MARGIN:g} x their largest "
                        f"difference, at least {GATE_FLOOR_K:g} K) and a ridge fitted on the other runs predicts it "
                        f"at least {RATIO:g} x their median error, or they are at least {INFLUENCE:g} x worse with it "
                        f"among them (fitting/broken_runs.py)",
                "refused": [r.as_dict() for r in self.refused], "named": [r.as_dict() for r in self.named]}


def _columns(tables: list[Table], names: tuple[str, ...], target: str) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Each run's temperatures (rows where all are finite) and, for the target rule, its rows with the target
    measured as (rises, target)."""
    readings, measured = [], []
    for t in tables:
        x = np.column_stack([np.asarray(t.column(n), float) for n in names])
        y = np.asarray(t.column(target), float)
        finite = np.isfinite(x).all(axis=1)
        readings.append(x[finite])
        first = x[np.argmax(finite)] if finite.any() else np.zeros(x.shape[1])
        rows = finite & np.isfinite(y)
        measured.append(np.column_stack([x[rows] - first, y[rows]]))
    return readings, measured


def _relation_shares(others: np.ndarray, own: np.ndarray, sensors: list[int]) -> dict[int, tuple[float, float]]:
    """Per sensor of `sensors`: (its largest |difference| in `own` from its relation on the other `sensors` fitted
    on `others` by least squares, the gate those rows give). Centred normal equations: one Gram matrix serves
    every relation."""
    mean = others.mean(axis=0)
    centred, own_centred = others - mean, own - mean
    gram = centred.T @ centred
    found = {}
    for i in sensors:
        rest = [j for j in sensors if j != i]
        slopes = np.linalg.lstsq(gram[np.ix_(rest, rest)], gram[rest, i], rcond=None)[0]
        gate = max(MARGIN * float(np.max(np.abs(centred[:, i] - centred[:, rest] @ slopes))), GATE_FLOOR_K)
        found[i] = (float(np.max(np.abs(own_centred[:, i] - own_centred[:, rest] @ slopes))), gate)
    return found


def _sensor_judgement(readings: list[np.ndarray], q: int, names: tuple[str, ...], culprit: bool
                      ) -> tuple[str, float, float]:
    """(sensor, its largest |difference| in run q, the gate from the other runs): the sensor closest to or furthest
    beyond its gate. With `culprit`, where some are beyond, the one without which the others agree best: one bad
    channel pulls every relation that leans on it (FL_THERMAL: a jump planted on t8_C put t11_C furthest out)."""
    others = np.vstack([r for k, r in enumerate(readings) if k != q])
    own = readings[q]
    every = list(range(len(names)))
    shares = _relation_shares(others, own, every)
    share = lambda i: shares[i][0] / shares[i][1]
    named = max(every, key=share)
    if culprit and share(named) > 1.0 and len(names) > 2:
        left = lambda i: max(d / g for d, g in _relation_shares(others, own, [j for j in every if j != i]).values())
        suspect = min(every, key=left)
        named = suspect if share(suspect) > 1.0 else named  # the sensor named is itself beyond its gate
    return (names[named], *shares[named])


def _errors(measured: list[np.ndarray]) -> list[float]:
    """Each run's RMSE when the ridge fitted on the other runs predicts it, the weight chosen leaving runs out."""
    design = np.vstack([m[:, :-1] for m in measured])
    sums = ridge.RunSums.of(design, np.concatenate([m[:, -1] for m in measured]), [len(m) for m in measured])
    columns = list(range(design.shape[1]))
    weight = min(zip(ridge.run_errors(sums, columns, ridge.WEIGHTS), ridge.WEIGHTS))[1]
    return [ridge.run_errors(sums, columns, [weight], [k])[0] for k in range(len(measured))]


def _judged(readings, measured, alive: list[int], labels: list[str], names) -> list[JudgedRun]:
    """Every run of `alive` judged against the others of `alive`."""
    within = _errors([measured[k] for k in alive])
    rows = [len(measured[k]) for k in alive]
    pooled = lambda errors, counts: math.sqrt(sum(e * e * n for e, n in zip(errors, counts)) / sum(counts))
    judged = []
    for p, k in enumerate(alive):
        others = [j for j in range(len(alive)) if j != p]
        without = _errors([measured[alive[j]] for j in others])
        counts = [rows[j] for j in others]
        before = pooled(without, counts)
        influence = pooled([within[j] for j in others], counts) / before if before > 0 else 1.0
        sensor, difference, gate = _sensor_judgement([readings[j] for j in alive], p, names, False)
        judged.append(JudgedRun(k, labels[k], sensor, difference, gate, within[p], float(np.median(without)),
                                influence))
    return judged


def _named(readings, alive: list[int], run: JudgedRun, names) -> JudgedRun:
    """`run` (judged among `alive`) with its culprit sensor named."""
    sensor, difference, gate = _sensor_judgement([readings[j] for j in alive], alive.index(run.index), names, True)
    return replace(run, sensor=sensor, difference_K=difference, gate_K=gate)


def screen_runs(tables: list[Table], temperatures: tuple[str, ...], target: str) -> Screening:
    """The runs refused (both rules failed), worst first, each after the runs refused before it are taken out,
    and the runs left whose sensors disagree though their target does not mind (named)."""
    names = tuple(dict.fromkeys(temperatures))
    if len(tables) < MIN_RUNS or len(names) < 2:
        return Screening()
    readings, measured = _columns(tables, names, target)
    if any(len(r) < len(names) + 1 for r in readings) or any(len(m) < 2 for m in measured):
        return Screening()  # a run too short to judge: the fit names what is wrong with it
    labels = run_labels([t.path for t in tables])
    alive = list(range(len(tables)))
    refused: list[JudgedRun] = []
    judged = _judged(readings, measured, alive, labels, names)
    while len(refused) < int(MAX_SHARE * len(tables)) and len(alive) > MIN_RUNS - 1:
        failing = [j for j in judged if j.sensors_disagree and j.target_off]
        if not failing:
            break
        worst = max(failing, key=lambda j: j.ratio)
        refused.append(_named(readings, alive, worst, names))
        alive.remove(worst.index)
        judged = _judged(readings, measured, alive, labels, names)
    return Screening(tuple(refused), tuple(_named(readings, alive, j, names) for j in judged if j.sensors_disagree))
