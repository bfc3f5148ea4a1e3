"""Detection table of `diagnose` on REAL data: effects injected into the FL_THERMAL recording.

    python benchmarks/diagnose_real.py [--channels ch3_um ch5_um] [--effects ...] [--seeds 3]
                                       [--first-seed 1] [--jobs 2] [--json results.json] [--size 0.6 1.0]

The synthetic machines (benchmarks/diagnose.py) are inside the baseline's class by construction;
a real machine is not. Here each effect is added, alone, to the measured columns of FL_THERMAL
(11115 rows every 15 s) and diagnosed as the README does: temperatures t5_C, t4_C, ambient t6_C,
speed spindle_rpm, target ch3_um or ch5_um, training part the first 24 h. The injections are
written here, apart from the library's own terms, so the diagnosis is not judged by its own model.

Parameters are drawn per seed (`np.random.default_rng(seed * 1000 + effect index)`, the same for
both channels). Every injected change is scaled to its peak: 0.5-2 K on each temperature it heats
or cools, a displacement of 4-8 um on ch3, 2-4 um on ch5 (random sign). Time constants 30-60 min
for the temperatures and again 30-60 min for the displacement behind them (it follows the
temperature rise, lagged once more), unless said otherwise:
- gear_ratio_switch: heat n [n > threshold] / n_max, threshold between two adjacent running speeds
  of the training part (so the training part shows both sides).
- coolant_switching: a hysteresis relay on t5_C (on at the 55-80th percentile of its training
  values, 0.5-2 K hysteresis) cools t5_C by 1-3 K through a lag. The relay reads the cooled
  temperature (the coolant cools its own switch, as a real controller does); t4_C is untouched.
- nonlinear_speed_heat: heat (n / n_max)^p, p 1.7-2.1, minus its least-squares affine part in n,
  so only the curvature is added (the baseline's class holds heat affine in n).
- slow_structure: a 4-8 h lag of the mean rise of t5_C and t4_C above their first values, on the
  displacement only.
- ambient_coupling: a 2-6 h lag of t6_C minus its mean, on the displacement only.
- sensor_offset: 0.4-1.5 K (random sign) on t5_C or t4_C from the first row.
- sensor_drift: 0.02-0.1 K/h (random sign) on t5_C or t4_C, from zero at the first row.
- outside the library, so any name is a wrong name: step (the displacement steps by the
  amplitude at 30-40 h, in the held-out part) and periodic (a sinusoid of 2-5 h period).
- none: the recording as measured, once per channel (it does not depend on the seed).
Not injected (see SKIPPED): feed_axis_heat and stop_convection.

Per channel and effect the table counts runs, runs whose effect is larger than 3 noise sigmas
(the standard deviation of the injected change over the recording, against the noise `diagnose`
estimates on that channel; the mean is left out because the baseline's constant terms take it),
the right name alone, beside others, a wrong name (any name that was not injected), the verdicts,
the held-out RMSE of the target before/after (mean over runs) and the seconds per diagnosis.
The summary per channel gives the right-alone share over the library runs whose effect exceeds
3 noise sigmas (target >= 80 %) and how many of those right names the clean recording gives too
(there the name may come from the recording's own misfit, not from the injection), the
wrong-name share over all runs (target <= 5 %), and the verdicts (with any names) of the clean
recording and of the step and periodic runs. Deterministic for the same arguments.
"""
from __future__ import annotations

import argparse
import sys
import time
from functools import lru_cache
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.runs import run_and_print  # noqa: E402  (before numpy: one BLAS thread per job)

import numpy as np  # noqa: E402
from scipy.signal import lfilter  # noqa: E402

from thermoplc.demo import recording  # noqa: E402
from thermoplc.diagnosis.search import diagnose  # noqa: E402
from thermoplc.physics.primitives import Series  # noqa: E402
from thermoplc.recordings.table import read_table  # noqa: E402

DT = 15.0
HOUR = 3600.0
TRAIN_UNTIL_S = 24 * HOUR
TEMPS = ("t5_C", "t4_C")
AMBIENT, SPEED = "t6_C", "spindle_rpm"
CHANNELS = ("ch3_um", "ch5_um")
AMPLITUDE_UM = {"ch3_um": (4.0, 8.0), "ch5_um": (2.0, 4.0)}
LIBRARY = ("gear_ratio_switch", "coolant_switching", "nonlinear_speed_heat", "slow_structure", "ambient_coupling",
           "sensor_offset", "sensor_drift")
OUTSIDE = ("step", "periodic")  # no library effect is either: a name for them is wrong
EFFECTS = (*LIBRARY, *OUTSIDE, "none")
SKIPPED = {
    "feed_axis_heat": "FL_THERMAL has no feed-rate column, so diagnose does not try it",
    "stop_convection": "other time constants at standstill change how each sensor relaxes toward its own "
                       "equilibrium, which only a model of that sensor (the thing being judged) can say; an extra "
                       "cooling switched by the spindle would be a gear switch at 0 rpm, not this effect"}
VISIBLE_SIGMAS = 3.0
TARGETS = {"right": 0.80, "wrong": 0.05}
VERDICTS = ("no_missing_effect", "explained", "unexplained", "insufficient_data")


@lru_cache(maxsize=1)
def columns() -> dict[str, np.ndarray]:
    return read_table(recording()).columns


def lag(x: np.ndarray, tau_s: float) -> np.ndarray:
    """First-order lag y[j] = a y[j-1] + (1-a) x[j], a = exp(-dt/tau), starting settled at x[0]."""
    a = np.exp(-DT / tau_s)
    return lfilter([1.0 - a], [1.0, -a], x, zi=[a * x[0]])[0]


def unit(x: np.ndarray) -> np.ndarray:
    """`x` scaled to a peak |value| of 1, so every change is sized by its peak."""
    peak = float(np.max(np.abs(x)))
    return x / peak if peak > 0.0 else x


def relay_cooling(temp: np.ndarray, on: float, off: float, cooling: float, tau_s: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Change of `temp` from a coolant switched on at `on` and off at `off` by the cooled reading,
    and the relay's state per row."""
    a = np.exp(-DT / tau_s)
    change, state = np.empty_like(temp), np.zeros(len(temp), dtype=bool)
    level, running = 0.0, False
    for j, reading in enumerate(temp):
        change[j] = -cooling * level
        running = reading + change[j] >= on or (running and reading + change[j] > off)
        state[j] = running
        level = a * level + (1.0 - a) * running
    return change, state


def heat_changes(heat: np.ndarray, rng: np.random.Generator, channel: str, amplitude: float
                 ) -> tuple[dict, dict]:
    """Both temperatures rise with a lag of `heat`; the displacement follows that rise, lagged again."""
    tau_t, tau_e = (float(tau) for tau in rng.uniform(30.0, 60.0, 2) * 60.0)
    rise = unit(lag(heat, tau_t))
    rises = {c: float(rng.uniform(0.5, 2.0)) for c in TEMPS}
    changes = {c: r * rise for c, r in rises.items()}
    changes[channel] = amplitude * unit(lag(rise, tau_e))
    return changes, {"tau_T_min": tau_t / 60, "tau_E_min": tau_e / 60, "rise_K": rises, "amplitude_um": amplitude}


def inject(name: str, data: dict, channel: str, seed: int, size: tuple[float, float] | None = None
           ) -> tuple[dict[str, np.ndarray], dict]:
    """The changes to add per column and the drawn parameters. `size`: the displacement's peak drawn in
    this range of multiples of the channel's standard deviation over the recording, instead of the fixed
    um ranges (about 0.2-0.4x); temperature changes, offsets and drifts keep their ranges."""
    rng = np.random.default_rng(seed * 1000 + EFFECTS.index(name))
    low, high = AMPLITUDE_UM[channel] if size is None else (float(np.std(data[channel])) * s for s in size)
    amplitude = float(rng.choice([-1.0, 1.0]) * rng.uniform(low, high))
    t, n = data["time_s"], data[SPEED]
    train = t <= TRAIN_UNTIL_S
    hours = (t - t[0]) / HOUR
    if name == "gear_ratio_switch":
        levels = np.unique(n[train & (n > 0)])
        k = int(rng.integers(len(levels) - 1))
        threshold = float(levels[k] + rng.uniform(0.2, 0.8) * (levels[k + 1] - levels[k]))
        changes, p = heat_changes(np.where(n > threshold, n, 0.0) / n.max(), rng, channel, amplitude)
        return changes, {"threshold_rpm": threshold, **p}
    if name == "nonlinear_speed_heat":
        exponent = float(rng.uniform(1.7, 2.1))
        x = n / n.max()
        affine = np.column_stack([np.ones_like(x), x])
        curve = x ** exponent - affine @ np.linalg.lstsq(affine, x ** exponent, rcond=None)[0]
        changes, p = heat_changes(curve, rng, channel, amplitude)
        return changes, {"exponent": exponent, **p}
    if name == "coolant_switching":
        on = float(np.quantile(data["t5_C"][train], rng.uniform(0.55, 0.8)))
        off = on - float(rng.uniform(0.5, 2.0))
        cooling = float(rng.uniform(1.0, 3.0))
        tau_t, tau_e = (float(tau) for tau in rng.uniform(30.0, 60.0, 2) * 60.0)
        change, state = relay_cooling(data["t5_C"], on, off, cooling, tau_t)
        return {"t5_C": change, channel: amplitude * unit(lag(change, tau_e))}, {
            "on_C": on, "off_C": off, "cooling_K": cooling, "tau_T_min": tau_t / 60, "tau_E_min": tau_e / 60,
            "switches_in_training": int(np.count_nonzero(np.diff(state[train]))), "amplitude_um": amplitude}
    if name == "slow_structure":
        tau = float(rng.uniform(4.0, 8.0))
        rise = np.mean([data[c] - data[c][0] for c in TEMPS], axis=0)
        return {channel: amplitude * unit(lag(rise, tau * HOUR))}, {"tau_h": tau, "amplitude_um": amplitude}
    if name == "ambient_coupling":
        tau = float(rng.uniform(2.0, 6.0))
        air = data[AMBIENT] - np.mean(data[AMBIENT])
        return {channel: amplitude * unit(lag(air, tau * HOUR))}, {"tau_h": tau, "amplitude_um": amplitude}
    if name in ("sensor_offset", "sensor_drift"):
        column, sign = str(rng.choice(TEMPS)), float(rng.choice([-1.0, 1.0]))
        if name == "sensor_offset":
            offset = sign * float(rng.uniform(0.4, 1.5))
            return {column: np.full_like(t, offset)}, {"column": column, "offset_K": offset}
        rate = sign * float(rng.uniform(0.02, 0.1))
        return {column: rate * hours}, {"column": column, "rate_K_per_h": rate}
    if name == "step":
        at = float(rng.uniform(30.0, 40.0))
        return {channel: amplitude * (hours >= at)}, {"at_h": at, "amplitude_um": amplitude}
    if name == "periodic":
        period, phase = float(rng.uniform(2.0, 5.0)), float(rng.uniform(0.0, 2 * np.pi))
        return {channel: amplitude * np.sin(2 * np.pi * hours / period + phase)}, {
            "period_h": period, "phase_rad": phase, "amplitude_um": amplitude}
    if name == "none":
        return {}, {}
    raise ValueError(name)


def series_of(use: dict[str, np.ndarray], channel: str) -> Series:
    return Series(DT, use["time_s"], use[SPEED], use[AMBIENT], np.column_stack([use[c] for c in TEMPS]), TEMPS,
                  use[channel], None)


def training_rows(share: float | None) -> int:
    """The training part: the first 24 h, or the first `share` of the rows (diagnose's default is 0.6)."""
    t = columns()["time_s"]
    return int(np.count_nonzero(t <= TRAIN_UNTIL_S)) if share is None else int(len(t) * share)


@lru_cache(maxsize=2)
def clean(channel: str, share: float | None):
    """The clean recording's own diagnosis: its final model (named effects included) is the baseline the
    injected runs are judged on with `--baseline`, as `diagnose --baseline CLEAN_MODEL` does."""
    return diagnose(series_of(columns(), channel), training_rows(share), channel)


def one(case: tuple) -> dict:
    channel, name, seed, size, share, on_clean = case
    data = columns()
    changes, parameters = inject(name, data, channel, seed, size)
    use = {**data, **{c: data[c] + change for c, change in changes.items()}}
    baseline = clean(channel, share) if on_clean else None
    start = time.perf_counter()
    d = diagnose(series_of(use, channel), training_rows(share), channel, None if baseline is None else baseline.final)
    seconds = time.perf_counter() - start
    size = {c: float(np.std(change) / max(d.sigma[c], 1e-12)) for c, change in changes.items()}
    return {"channel": channel, "effect": name, "seed": seed, "parameters": parameters, "verdict": d.verdict,
            "found": [e["name"] for e in d.named], "reason": d.reason, "before": d.before.rmse_held_out[channel],
            "after": d.after.rmse_held_out[channel], "seconds": seconds, "size_sigmas": size}


def visible(r: dict) -> bool:
    """The injected change moves some channel by more than `VISIBLE_SIGMAS` of its noise."""
    return max(r["size_sigmas"].values(), default=0.0) > VISIBLE_SIGMAS


def wrong_name(r: dict) -> bool:
    return any(f != r["effect"] for f in r["found"])


def right_alone(r: dict) -> bool:
    return r["effect"] in LIBRARY and r["found"] == [r["effect"]]


def _share(part: list, whole: list) -> str:
    return f"{len(part)}/{len(whole)} ({100 * len(part) / max(len(whole), 1):.0f} %)"


def table(results: list[dict]) -> list[str]:
    lines = ["| channel | effect | runs | > 3 sigma | right alone | right + others | wrong name | no_missing_effect "
             "| explained | unexplained | insufficient | RMSE before | after | s mean | s max |",
             "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for channel in CHANNELS:
        for name in EFFECTS:
            rows = [r for r in results if (r["channel"], r["effect"]) == (channel, name)]
            if not rows:
                continue
            verdicts = [r["verdict"] for r in rows]
            others = sum(name in r["found"] and len(r["found"]) > 1 for r in rows)
            lines.append(
                f"| {channel} | `{name}` | {len(rows)} | {sum(map(visible, rows))} | {sum(map(right_alone, rows))} | "
                f"{others} | {sum(map(wrong_name, rows))} | "
                + " | ".join(str(verdicts.count(v)) for v in VERDICTS)
                + f" | {np.mean([r['before'] for r in rows]):.3f} | {np.mean([r['after'] for r in rows]):.3f} | "
                f"{np.mean([r['seconds'] for r in rows]):.1f} | {np.max([r['seconds'] for r in rows]):.1f} |")
    return lines


def _said(r: dict) -> str:
    return r["verdict"] + (f" naming {', '.join(r['found'])}" if r["found"] else "")


def summary(results: list[dict]) -> list[str]:
    """Per channel. A right name the clean recording gives as well is counted, and how many such
    there are is said: on real data the recording's own misfit may carry that name."""
    lines = []
    for channel in CHANNELS:
        rows = [r for r in results if r["channel"] == channel]
        if not rows:
            continue
        library = [r for r in rows if r["effect"] in LIBRARY]
        shown = [r for r in library if visible(r)]
        clean_names = {f for r in rows if r["effect"] == "none" for f in r["found"]}
        said = {name: "; ".join(_said(r) for r in rows if r["effect"] == name) or "not run"
                for name in ("none", *OUTSIDE)}
        right = [r for r in shown if right_alone(r)]
        lines.append(
            f"{channel}: right name alone {_share(right, shown)} of the library runs whose effect exceeds "
            f"{VISIBLE_SIGMAS:g} noise sigmas [target >= {TARGETS['right']:.0%}], "
            f"{sum(r['effect'] in clean_names for r in right)} of them a name the clean recording gives too "
            f"({_share([r for r in library if right_alone(r)], library)} of all library runs); a wrong name "
            f"{_share([r for r in rows if wrong_name(r)], rows)} of all runs [target <= {TARGETS['wrong']:.0%}]; "
            f"clean recording: {said['none']}; step: {said['step']}; periodic: {said['periodic']}")
    return lines


def arguments(description: str, effects: tuple[str, ...], beside: bool = False) -> argparse.Namespace:
    """The options every FL_THERMAL injection benchmark takes: channels, effects, seeds, jobs, JSON, size;
    `beside`: also --with-diagnose (the oracle's benchmark runs diagnose on the same runs)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--channels", nargs="+", choices=CHANNELS, default=list(CHANNELS))
    parser.add_argument("--effects", nargs="+", choices=effects, default=list(effects))
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--json", help="also write every run's result here")
    parser.add_argument("--size", nargs=2, type=float, metavar=("LOW", "HIGH"),
                        help="the injected displacement's peak in this range of multiples of the channel's standard "
                             "deviation (default: 4-8 um on ch3, 2-4 um on ch5, about 0.2-0.4x)")
    parser.add_argument("--train-share", type=float, help="train on this share of the rows (diagnose's default: "
                        "0.6) instead of the first 24 h")
    parser.add_argument("--baseline", action="store_true", help="judge each injected run on the clean recording's "
                        "diagnosed model (diagnose --baseline CLEAN_MODEL), named effects included")
    if beside:
        parser.add_argument("--with-diagnose", action="store_true", help="run diagnose on each run too, beside the oracle")
    return parser.parse_args()


def main() -> None:
    args = arguments(__doc__.splitlines()[0], EFFECTS)
    for name, why in SKIPPED.items():
        print(f"not injected: {name}: {why}")
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    size = tuple(args.size) if args.size else None
    cases = [(channel, name, seed, size, args.train_share, args.baseline) for channel in args.channels
             for name in args.effects for seed in (seeds[:1] if name == "none" else seeds)]
    results = run_and_print(one, cases, args.jobs, args.json, table, summary)
    for r in results:
        if not right_alone(r):
            print(f"  {r['channel']} {r['effect']} seed {r['seed']}: {r['verdict']} {r['found']} {r['reason'] or ''} "
                  f"sigmas {r['size_sigmas']} {r['parameters']}")


if __name__ == "__main__":
    main()
