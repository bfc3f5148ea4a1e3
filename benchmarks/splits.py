"""Every kind on FL_THERMAL over a sweep of training splits (issue 50): a user's split is any split.

    python -m benchmarks.splits              # ch3 and ch5, splits 40..75 % in 5 % steps, every kind
    python -m benchmarks.splits --quick      # ch3, three splits, the closed-form kinds
    python -m benchmarks.splits --choose 4   # each kind chooses at most 4 of every sensor on its training part

Each kind is fitted on the first share of the recording (the sensors of the issue: t8, t4, t5, t11; ambient
t6 and the spindle speed where a kind reads them) and judged on the rest: held-out RMSE um per split, the
worst and the median beside no compensation (the held-out rows themselves) and the ridge floor (every
temperature's rise, ridge weight by forward validation on the training rows: base/ridge.py). The last
columns: the worst ratio to mlr on the same split and the worst ratio to the ridge floor. Seeded.
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import argparse
import time

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.demo import AMBIENT, SPEED, recording
from thermoplc.base import ridge
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.models.reference import model_inputs, predict
from thermoplc.recordings.table import read_table

TEMPS = ("t8_C", "t4_C", "t5_C", "t11_C")
KINDS = ("mlr", "dlag", "gm0n", "gm1n", "bayes", "lumped", "kalman")
QUICK_KINDS = ("mlr", "dlag", "gm0n", "gm1n")
NEEDS_SPEED_AND_AMBIENT = ("kalman", "lumped")
SHARES = tuple(np.round(np.arange(0.40, 0.751, 0.05), 2))


def held_out_rmse(model, table, split: int) -> float:
    residual = predict(model, model_inputs(model, table), "f64")[model.target.name][split:] - \
        table.columns[model.target.column][split:]
    return float(np.sqrt(np.mean(residual ** 2)))


def ridge_floor(table, channel: str, split: int) -> float:
    """A plain ridge on every temperature's rise, its weight by forward validation on the training rows."""
    names = [c for c in table.columns if c.startswith("t") and c.endswith("_C")]
    rises = np.column_stack([table.columns[c] - table.columns[c][0] for c in names])
    fitted = ridge.fit_linear(rises[:split], table.columns[channel][:split], names)
    residual = fitted.intercept + rises[split:] @ fitted.slopes - table.columns[channel][split:]
    return float(np.sqrt(np.mean(residual ** 2)))


def sweep(table, channel: str, kinds, shares, choose: int = 0) -> None:
    t = table.columns["time_s"]
    splits = [int(np.searchsorted(t, t[0] + share * (t[-1] - t[0]), side="right")) for share in shares]
    every = tuple(c for c in table.columns if c.startswith("t") and c.endswith("_C") and c != AMBIENT)
    sensors = f"at most {choose} of {len(every)} chosen on the training part" if choose else ",".join(TEMPS)
    print(f"\nFL_THERMAL {channel}, sensors {sensors}: held-out RMSE um by training share (trained until h)")
    head = "".join(f"{f'{s:.0%} ({t[k - 1] / 3600:.1f})':>14}" for s, k in zip(shares, splits))
    print(f"{'kind':<8}{head}{'worst':>8}{'median':>8}{'/mlr worst':>11}{'/ridge worst':>13}{'s':>6}")
    rows = {"none": [float(np.sqrt(np.mean(table.columns[channel][k:] ** 2))) for k in splits],
            "ridge": [ridge_floor(table, channel, k) for k in splits]}
    for name in ("none", "ridge"):
        print(f"{name:<8}" + "".join(f"{v:>14.2f}" for v in rows[name]) +
              f"{max(rows[name]):>8.2f}{np.median(rows[name]):>8.2f}", flush=True)
    for kind in kinds:
        extra = (SPEED, AMBIENT) if kind in NEEDS_SPEED_AND_AMBIENT else (None, None)
        started, found = time.perf_counter(), []
        for k in splits:
            request = FitRequest(kind, channel, every if choose else TEMPS, *extra, train_rows=k,
                                 settings={"seed": 0}, choose_sensors=choose)
            try:
                found.append(held_out_rmse(fit([table], request), table, k))
            except UserError:
                found.append(float("nan"))
        rows[kind] = found
        to_mlr = max(a / b for a, b in zip(found, rows["mlr"])) if "mlr" in rows else float("nan")
        to_ridge = max(a / b for a, b in zip(found, rows["ridge"]))
        print(f"{kind:<8}" + "".join(f"{v:>14.2f}" for v in found) + f"{np.nanmax(found):>8.2f}"
              f"{np.nanmedian(found):>8.2f}{to_mlr:>11.2f}{to_ridge:>13.2f}{time.perf_counter() - started:>6.0f}",
              flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="ch3, three splits, the closed-form kinds")
    parser.add_argument("--choose", type=int, default=0, metavar="N",
                        help="each kind chooses at most N of every sensor (but the ambient) on its training part")
    parser.add_argument("--kinds", default=",".join(KINDS), help="comma-separated (default: every kind)")
    args = parser.parse_args()
    table = read_table(recording())
    shares = (0.4, 0.6, 0.75) if args.quick else SHARES
    for channel in ("ch3_um",) if args.quick else ("ch3_um", "ch5_um"):
        sweep(table, channel, QUICK_KINDS if args.quick else tuple(args.kinds.split(",")), shares, args.choose)


if __name__ == "__main__":
    main()
