"""The limits every block takes from its recording (issue 61, models/envelope.py) against the fixed ones before.

    python benchmarks/limits.py [--quick]

On FL_THERMAL ch3 and the cascade twin (benchmarks/kinds_on_data.py: the demo's sensors, fit on the first 24 h),
for each kind and the fused mlr block: the envelope `fit` recorded (largest |drift| measured and modelled, the
fastest change per call measured and modelled, the largest |speed|), the clamp, rate limit and speed guard
`generate` takes from it, and the block's held-out RMSE (guards, rate limit and clamp as the PLC runs them;
fused: a probing every 120 calls) with the fixed limits (+-300 um, 2 um per call, +-100,000 rpm) and with the
recording's, with the share of held-out calls the rate limit acted on. `--quick`: mlr, kalman and dlag. Seeded.
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.kinds_on_data import PROBE_EVERY, fitted_kinds, split_row  # noqa: E402
from thermoplc.models.probing import PROBE_NEW, PROBE_VALUE, probings  # noqa: E402
from thermoplc.models.reference import block_outputs, model_inputs  # noqa: E402
from thermoplc.models.safety import LIMITED, Limits  # noqa: E402

KINDS = ("mlr", "kalman", "lumped", "dlag", "gm0n", "gm1n", "bayes", "bpnn", "piecewise")
QUICK = ("mlr", "kalman", "dlag")


def held_out(model, table, limits: Limits) -> tuple[float, float]:
    """(held-out RMSE of the block, share of held-out calls rate-limited)."""
    split = split_row(table)
    inputs = model_inputs(model, table)
    measured = table.columns[model.target.column]
    if model.probe is not None:
        value, new = probings(measured, PROBE_EVERY)
        inputs = {**inputs, PROBE_VALUE: value, PROBE_NEW: new}
    out = block_outputs(model, inputs, "f32", limits)
    error = out[model.target.name].astype(np.float64)[split:] - measured[split:]
    return float(np.sqrt(np.mean(error ** 2))), float(np.mean(out[LIMITED][split:]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    kinds = QUICK if parser.parse_args().quick else KINDS
    print("um, um per call, rpm; envelope: measured/model; RMSE: fixed limits -> the recording's (change)")
    print(f"{'data':<12}{'kind':<11}{'drift':>13}{'step':>12}{'speed':>7}{'clamp':>7}{'rate':>6}{'guard':>8}"
          f"{'held-out RMSE':>26}{'limited':>9}")
    worst = 0.0
    for label, kind, table, model in fitted_kinds(Path(tempfile.mkdtemp(prefix="thermoplc-limits-")), kinds):
        if isinstance(model, str):
            print(f"{label:<12}{kind:<11}refused: {model}")
            continue
        e, limits = model.envelope, Limits.for_model(model)
        before, _ = held_out(model, table, Limits())
        after, limited = held_out(model, table, limits)
        worst = max(worst, after / before - 1)
        speed = f"{e.speed_rpm:>7.0f}" if e.speed_rpm is not None else f"{'-':>7}"
        print(f"{label:<12}{kind:<11}{e.drift_um[0]:>6.1f}/{e.drift_um[1]:<6.1f}"
              f"{e.step_um[0]:>5.2f}/{e.step_um[1]:<6.2f}"
              f"{speed}{limits.max_output:>7g}{limits.max_step:>6g}{limits.max_speed_rpm:>8g}"
              f"{before:>9.3f} -> {after:<7.3f}({100 * (after / before - 1):+5.1f}%){100 * limited:>8.1f}%", flush=True)
    print(f"largest change of a held-out RMSE: {100 * worst:+.1f}%")


if __name__ == "__main__":
    main()
