"""Every model kind on the real FL_THERMAL recording, ch3 and ch5: fit on the first 24 h, predict the rest.

    python benchmarks/fl_thermal.py

Sensors: at most four, chosen on the training part only by paper 000's fuzzy clustering with
grey relational grades (`select-sensors --method fcm-grey --max-groups 4`); the spindle speed and
ambient t6_C (the sensor with the smallest spread that does not follow the speed) where a kind
needs them. Beside: no compensation (the measured error itself, and its standard deviation) and
MLR on all 16 sensors. Prints held-out RMSE and max |residual| per kind, and beside it the pooled
RMSE of forward cross-validation over four blocks (`fit --folds 4`: each of the last three blocks
predicted by a fit on the blocks before it) with the range of the folds; a kind the data does not
allow is printed with the fit's reason. Last, `fit --model auto` over the 15 temperatures besides
the ambient: once on the first 24 h alone (its choice fitted there and judged on the rest) and once
by the four-block cross-validation of the whole recording. Seeded: the same run prints the same table.
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import time
from dataclasses import replace

import numpy as np

from thermoplc.demo import AMBIENT, SPEED, TRAIN_UNTIL_S, recording
from thermoplc.base.errors import UserError
from thermoplc.fitting.auto import rank
from thermoplc.fitting.crossval import cuts, fit_cross_validated
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.models.reference import model_inputs, predict
from thermoplc.fitting.selection import select_sensors
from thermoplc.recordings.table import read_table

CHANNELS = ("ch3_um", "ch5_um")
KINDS = ("mlr", "kalman", "lumped", "dlag", "gm0n", "gm1n", "bayes", "bpnn")
NEEDS_SPEED_AND_AMBIENT = ("kalman", "lumped")
MAX_SENSORS = 4
FOLDS = 4  # forward cross-validation: blocks of 11.6 h, three folds


def held_out(model, table, split: int) -> tuple[float, float]:
    target = model.target
    residual = (predict(model, model_inputs(model, table), "f64")[target.name][split:]
                - table.columns[target.column][split:])
    return float(np.sqrt(np.mean(residual ** 2))), float(np.max(np.abs(residual)))


def cross_validated(table, request) -> str:
    """Pooled RMSE of forward cross-validation over `FOLDS` blocks (fit --folds), with the folds'
    spread; the sensors stay those chosen on the first 24 h."""
    try:
        held = fit_cross_validated([table], request, FOLDS).metrics["held_out"]
    except UserError:
        return "refused in a fold"
    low, high = held["fold_rmse_um"]
    return f"{held['rmse_um']:.2f} ({low:.1f}..{high:.1f})"


def no_compensation_folds(table, channel: str) -> float:
    """RMSE of compensating nothing on the rows the folds predict (cut by time alone: a kind that
    reads the speed moves each cut to a standstill, a few rows away)."""
    first = cuts(table, "time_s", FOLDS, None)[0]
    return float(np.sqrt(np.mean(table.columns[channel][first:] ** 2)))


def chosen_sensors(table, channel: str, split: int) -> tuple[str, ...]:
    candidates = {c: table.columns[c][:split] for c in table.columns if c.startswith("t") and c.endswith("_C")
                  and c != AMBIENT}
    return select_sensors(candidates, table.columns[channel][:split], "fcm-grey", max_groups=MAX_SENSORS).chosen


def main() -> None:
    table = read_table(recording())
    split = int(np.searchsorted(table.columns["time_s"], table.columns["time_s"][0] + TRAIN_UNTIL_S, side="right"))
    every = tuple(c for c in table.columns if c.startswith("t") and c.endswith("_C"))
    print(f"FL_THERMAL: {table.rows} rows, fit on the first {split} (24 h), held out {table.rows - split}")
    print(f"{'channel':<8}{'kind':<10}{'sensors':<30}{'held-out RMSE um':>18}{'max |res| um':>14}{'fit s':>8}"
          f"{f'{FOLDS}-block CV RMSE um':>24}")
    for channel in CHANNELS:
        measured = table.columns[channel][split:]
        print(f"{channel:<8}{'none':<10}{'(no compensation; std)':<30}{np.sqrt(np.mean(measured ** 2)):>18.2f}"
              f"{np.max(np.abs(measured)):>14.2f}{'':>8}{no_compensation_folds(table, channel):>24.2f}"
              f"   std {np.std(measured):.2f}")
        request = FitRequest("mlr", channel, every, train_rows=split)
        rmse, worst = held_out(fit([table], request), table, split)
        print(f"{channel:<8}{'mlr':<10}{'all 16 sensors':<30}{rmse:>18.2f}{worst:>14.2f}{'':>8}"
              f"{cross_validated(table, request):>24}")
        sensors = chosen_sensors(table, channel, split)
        for kind in KINDS:
            extra = (SPEED, AMBIENT) if kind in NEEDS_SPEED_AND_AMBIENT else (None, None)
            request = FitRequest(kind, channel, sensors, *extra, train_rows=split, settings={"seed": 0})
            start = time.perf_counter()
            try:
                model = fit([table], request)
            except UserError as exc:
                print(f"{channel:<8}{kind:<10}{','.join(sensors):<30}  refused: {str(exc).split(': ', 1)[-1]}")
                continue
            rmse, worst = held_out(model, table, split)
            seconds = time.perf_counter() - start
            print(f"{channel:<8}{kind:<10}{','.join(sensors):<30}{rmse:>18.2f}{worst:>14.2f}{seconds:>8.1f}"
                  f"{cross_validated(table, request):>24}", flush=True)
        auto_rows(table, channel, split)


def auto_rows(table, channel: str, split: int) -> None:
    """`fit --model auto --folds 4` twice: on the first 24 h alone, its choice then fitted there and
    judged on the 22 h it never saw; and on the whole recording, judged by its own folds (the
    choice among candidates by the same folds makes that number slightly optimistic)."""
    candidates = tuple(c for c in table.columns if c.startswith("t") and c.endswith("_C") and c != AMBIENT)
    request = FitRequest("auto", channel, candidates, SPEED, AMBIENT, settings={"seed": 0})
    start = time.perf_counter()
    first_day = best(rank([table.head(split)], request, FOLDS, "time_s"))
    chosen = replace(request, kind=first_day.kind, temps=first_day.sensors, train_rows=split)
    rmse, worst = held_out(fit([table], chosen), table, split)
    seconds = time.perf_counter() - start
    print(f"{channel:<8}{'auto':<10}{describe(first_day):<30}{rmse:>18.2f}{worst:>14.2f}{seconds:>8.1f}"
          f"{'(chosen on the first 24 h)':>30}", flush=True)
    start = time.perf_counter()
    whole = best(rank([table], request, FOLDS, "time_s"))
    held = whole.model.metrics["held_out"]
    low, high = held["fold_rmse_um"]
    pooled = f"{held['rmse_um']:.2f} ({low:.1f}..{high:.1f})"
    print(f"{channel:<8}{'auto':<10}{describe(whole):<30}{'':>18}{'':>14}{time.perf_counter() - start:>8.1f}"
          f"{pooled:>24}", flush=True)


def best(ranked):
    """The first candidate generate accepts (auto writes it)."""
    return next(c for c in ranked if c.model is not None and c.not_accepted is None)


def describe(candidate) -> str:
    return f"{candidate.kind}: {','.join(s.removesuffix('_C') for s in candidate.sensors)}"


if __name__ == "__main__":
    main()
