"""Detection table of `diagnose`: each effect hidden alone in twin data, over seeds and noise levels.

    python benchmarks/diagnose.py [--seeds 5] [--noise 1 2] [--hours 72] [--jobs 2]

Per effect and noise level: how often the hidden effect was named (detection), how many other
names were added (wrong names), the held-out RMSE before/after in the channel the effect shows
in, and the run time. A run with nothing hidden gives the false-alarm rate.
"""
from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from thermoplc.diagnosis.search import diagnose
from thermoplc.models.effects import NAMES, SHOWS_IN as EFFECT_CHANNELS, Effect
from thermoplc.models.simulation import Series
from thermoplc.models.twin import simulate

TEMPS = ("T_motor", "T_bearing")
SHOWS_IN = {**EFFECT_CHANNELS, "none": "E_z_um"}


def one(case: tuple[str, int, float, float]) -> dict:
    name, seed, noise, hours = case
    effects = () if name == "none" else (Effect.parse(name),)
    columns = simulate(hours, seed, effects=effects, noise=noise)
    series = Series(10.0, columns["time_s"], columns["n_rpm"], columns["T_env"],
                    np.column_stack([columns[c] for c in TEMPS]), TEMPS, columns["E_z_um"], columns["v_feed_mm_min"])
    start = time.perf_counter()
    d = diagnose(series, int(0.6 * series.rows), "E_z_um")
    seconds = time.perf_counter() - start
    found = [e["name"] for e in d.added]
    channel = SHOWS_IN[name]
    detected = d.verdict == "no_missing_effect" if name == "none" else name in found
    return {"effect": name, "noise": noise, "detected": detected, "wrong": len([f for f in found if f != name]),
            "before": d.before.rmse_held_out[channel], "after": d.after.rmse_held_out[channel], "seconds": seconds}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--noise", type=float, nargs="+", default=[1.0, 2.0])
    parser.add_argument("--hours", type=float, default=72.0)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    cases = [(name, seed, noise, args.hours) for name in (*NAMES, "none") for noise in args.noise
             for seed in range(1, args.seeds + 1)]
    with ProcessPoolExecutor(args.jobs) as pool:
        results = list(pool.map(one, cases))
    print(f"{'effect':<22}{'noise':>6}{'detected':>10}{'wrong names':>13}{'channel':>10}"
          f"{'RMSE before':>13}{'after':>8}{'seconds':>9}")
    for name in (*NAMES, "none"):
        for noise in args.noise:
            rows = [r for r in results if r["effect"] == name and r["noise"] == noise]
            print(f"{name:<22}{noise:>6g}{sum(r['detected'] for r in rows):>6}/{len(rows):<3}"
                  f"{sum(r['wrong'] for r in rows):>13}{SHOWS_IN[name]:>10}"
                  f"{np.mean([r['before'] for r in rows]):>13.3f}{np.mean([r['after'] for r in rows]):>8.3f}"
                  f"{np.mean([r['seconds'] for r in rows]):>9.1f}")
    print("detected: the effect was named (for 'none': verdict no_missing_effect); wrong names: other effects "
          "added, summed over runs; RMSE: held-out, mean over runs, in the channel the effect shows in (K or um)")


if __name__ == "__main__":
    main()
