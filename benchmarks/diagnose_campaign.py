"""Detection table of `diagnose` on campaigns: twin campaigns with an effect hidden in every run, or in some.

    python benchmarks/diagnose_campaign.py [--machines cascade portal] [--seeds 3] [--first-seed 1]
                                           [--runs 6] [--hours 12] [--some] [--ambient-levels 14,20,26,33]
                                           [--jobs 2] [--json results.json]

Each case is a campaign of one synthetic machine (`thermoplc twin --runs N`: hall air spread over
14-34 degC, every third run swinging, every other one warm at the start), the effect drawn per seed
from the first run as benchmarks/diagnose.py draws it and hidden in every run (`--some`: in the
first half of the runs only, so the training runs carry it and the held-out runs partly not). The
diagnosis reads it as `diagnose --data FOLDER` does: the first 60 % of the runs train, the others
are held out, evidence pooled (diagnosis.search.diagnose_runs). `--ambient-levels`: the designed ambient
experiment instead (`twin --ambient-levels`: every run soaked at 20 degC, the air stepped to the levels in
turn as it starts), so the held-out runs sit at the training runs' levels. Per machine and effect: runs, the
right name alone, beside others, a wrong name, the verdicts, the target's held-out RMSE before and
after and the seconds per campaign. Targets (issue 39, every run carrying the effect): right alone
>= 90 %, a wrong name <= 2 %, "none" names nothing. Deterministic for the same arguments.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.runs import run_and_print  # noqa: E402  (before numpy: one BLAS thread per job)

import numpy as np  # noqa: E402

from benchmarks.diagnose import series_of  # noqa: E402
from thermoplc.diagnosis.parts import Parts  # noqa: E402
from thermoplc.diagnosis.search import diagnose_runs  # noqa: E402
from thermoplc.machines import MACHINES, machine  # noqa: E402
from thermoplc.machines.campaign import plan, simulate_run  # noqa: E402
from thermoplc.machines.random_effects import draw  # noqa: E402
from thermoplc.physics.effects import NAMES  # noqa: E402

TRAIN_SHARE = 0.6
DT = 10.0
TARGETS = {"right": 0.90, "wrong": 0.02}


def one(case: tuple) -> dict:
    machine_name, name, seed, runs, hours, some, levels = case
    chosen = machine(machine_name)
    plans = plan(runs, seed, levels=levels)
    first = simulate_run(machine_name, plans[0], hours, DT, 0.0)
    effect = None if name == "none" else draw(name, chosen, first, len(first["time_s"]), seed)
    hidden = range(1, runs // 2 + 1) if some else None
    plans = plan(runs, seed, (effect,) if effect else (), tuple(hidden) if hidden else None, levels)
    series = [series_of(chosen, simulate_run(machine_name, p, hours, DT, 0.0)) for p in plans]
    training = max(1, int(TRAIN_SHARE * runs))
    parts = Parts(tuple(series), tuple(s.rows if k < training else 0 for k, s in enumerate(series)),
                  tuple(f"run {k + 1}" for k in range(runs)))
    start = time.perf_counter()
    d = diagnose_runs(parts, "E_z_um")
    seconds = time.perf_counter() - start
    return {"machine": machine_name, "effect": name, "seed": seed, "runs": runs, "hours": hours, "some": some,
            "ambient_levels": list(levels) if levels else None,
            "parameters": dict(effect.parameters) if effect else {}, "verdict": d.verdict,
            "found": [e["name"] for e in d.named], "added": [e["name"] for e in d.added], "reason": d.reason,
            "before": d.before.rmse_held_out["E_z_um"], "after": d.after.rmse_held_out["E_z_um"],
            "seconds": seconds}


def outcome(r: dict) -> str:
    if r["effect"] == "none":
        return "wrong" if r["found"] else "right"
    if r["found"] == [r["effect"]]:
        return "right"
    if r["effect"] in r["found"]:
        return "right+others"
    return "wrong" if r["found"] else "not named"


def wrong_name(r: dict) -> bool:
    return any(f != r["effect"] for f in r["found"])


def table(results: list[dict]) -> list[str]:
    lines = ["| machine | effect | campaigns | right alone | right + others | not named | wrong name | verdicts "
             "| held-out RMSE before um | after | s mean |",
             "| --- | --- | ---: | ---: | ---: | ---: | ---: | --- | ---: | ---: | ---: |"]
    for machine_name in MACHINES:
        for name in (*NAMES, "none"):
            rows = [r for r in results if (r["machine"], r["effect"]) == (machine_name, name)]
            if not rows:
                continue
            kinds = [outcome(r) for r in rows]
            verdicts = ", ".join(f"{v} {sum(r['verdict'] == v for r in rows)}"
                                 for v in sorted({r["verdict"] for r in rows}))
            lines.append(f"| {machine_name} | `{name}` | {len(rows)} | {kinds.count('right')} | "
                         f"{kinds.count('right+others')} | {kinds.count('not named')} | {sum(map(wrong_name, rows))} "
                         f"| {verdicts} | {np.mean([r['before'] for r in rows]):.2f} | "
                         f"{np.mean([r['after'] for r in rows]):.2f} | {np.mean([r['seconds'] for r in rows]):.1f} |")
    return lines


def summary(results: list[dict]) -> list[str]:
    lines = []
    share = lambda part, whole: f"{len(part)}/{len(whole)} ({100 * len(part) / max(len(whole), 1):.0f} %)"
    for machine_name in MACHINES:
        rows = [r for r in results if r["machine"] == machine_name]
        if not rows:
            continue
        hidden = [r for r in rows if r["effect"] != "none"]
        clean = [r for r in rows if r["effect"] == "none"]
        lines.append(f"{machine_name}: right name alone {share([r for r in hidden if outcome(r) == 'right'], hidden)}"
                     f" [target >= {TARGETS['right']:.0%}]; a wrong name {share([r for r in rows if wrong_name(r)], rows)}"
                     f" [target <= {TARGETS['wrong']:.0%}]; clean campaigns naming nothing "
                     f"{share([r for r in clean if outcome(r) == 'right'], clean)}; seconds per campaign mean "
                     f"{np.mean([r['seconds'] for r in rows]):.1f}, max {np.max([r['seconds'] for r in rows]):.1f}")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--machines", nargs="+", choices=list(MACHINES), default=list(MACHINES))
    parser.add_argument("--effects", nargs="+", choices=[*NAMES, "none"], default=[*NAMES, "none"])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--runs", type=int, default=6)
    parser.add_argument("--hours", type=float, default=12.0)
    parser.add_argument("--some", action="store_true", help="hide the effect in the first half of the runs only")
    parser.add_argument("--ambient-levels", type=lambda text: tuple(float(v) for v in text.split(",")),
                        help="the designed ambient experiment: the air stepped from 20 degC to these levels in turn")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--json", help="also write every campaign's result here")
    args = parser.parse_args()
    cases = [(m, name, seed, args.runs, args.hours, args.some, args.ambient_levels) for m in args.machines for name in args.effects
             for seed in range(args.first_seed, args.first_seed + args.seeds)]
    results = run_and_print(one, cases, args.jobs, args.json, table, summary)
    for r in results:
        if outcome(r) != "right":
            print(f"  {r['machine']} {r['effect']} seed {r['seed']}: {r['verdict']} named {r['found']} "
                  f"added {r['added']} {r['parameters']}")


if __name__ == "__main__":
    main()
