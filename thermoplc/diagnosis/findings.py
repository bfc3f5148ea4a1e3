"""What the diagnosis found, as the findings document (findings.json) and as console text."""
from __future__ import annotations

import shlex
from pathlib import Path

import numpy as np

from thermoplc.diagnosis import sufficiency
from thermoplc.diagnosis.judges import BIC_MARGIN
from thermoplc.diagnosis.rules import run_label, showing_run_indexes
from thermoplc.diagnosis.search import Diagnosis, Trial
from thermoplc.diagnosis.windows import Window, measured, rms
from thermoplc.physics.primitives import Series

FORMAT = "thermoplc-findings"
VERSION = 1


def conditions(series: Series, w: Window, residual: np.ndarray) -> dict:
    """Operating conditions inside a window: what an engineer checks first."""
    rows = slice(w.start, w.stop)
    n = series.n[rows]
    running = float(np.mean(n > 0.01 * max(float(np.max(np.abs(series.n))), 1.0)))
    found = {
        "speed_rpm": [float(n.min()), float(n.max())],
        "spindle": "running" if running == 1.0 else "stopped" if running == 0.0 else f"mixed ({running:.0%} running)",
        "ambient_C": [float(series.te[rows].min()), float(series.te[rows].max())],
        "hours_since_start": [float((series.t[w.start] - series.t[0]) / 3600),
                              float((series.t[w.stop - 1] - series.t[0]) / 3600)],
        "measured_minus_simulated_mean": float(np.mean(measured(residual[rows]))),
    }
    if series.feed is not None:
        found["feed_mm_min"] = [float(series.feed[rows].min()), float(series.feed[rows].max())]
    return found


def _window(w: Window, d: Diagnosis, after: bool) -> dict:
    parts = d.parts
    series = parts.runs[w.run]
    entry = {**({"run": parts.labels[w.run]} if parts.campaign else {}),
             "start_s": float(series.t[w.start]), "end_s": float(series.t[w.stop - 1]), "channel": w.channel,
             "rms": w.rms}
    if after:
        entry["rms_after"] = rms(parts.unpool(d.residual_after[w.channel])[w.run][w.start:w.stop])
    residual = (d.residual_before if after else d.residual_after)[w.channel]
    entry["conditions"] = conditions(series, w, parts.unpool(residual)[w.run])
    return entry


def per_run(d: Diagnosis) -> list[dict]:
    """Each run: whether it trains or is held out, the hall air it ran in (lowest and highest reading), its target's
    RMSE before and after on its training and held-out rows, and its disagreement windows before and after: where
    the gap was and how it shrank, with the air each ran in."""
    parts, target = d.parts, d.channels[-1]
    before, after = parts.unpool(d.residual_before[target]), parts.unpool(d.residual_after[target])
    rows = []
    for k, (run, n) in enumerate(zip(parts.runs, parts.train_rows)):
        role = "training" if n == run.rows else "held out" if n == 0 else "split"
        rows.append({"run": parts.labels[k] if parts.labels else str(k + 1), "role": role, "rows": run.rows,
                     "ambient_C": [float(np.min(run.te)), float(np.max(run.te))],
                     "train_rmse_before_um": rms(before[k][:n]), "train_rmse_after_um": rms(after[k][:n]),
                     "held_out_rmse_before_um": rms(before[k][n:]), "held_out_rmse_after_um": rms(after[k][n:]),
                     "windows_before": sum(w.run == k for w in d.windows_before),
                     "windows_after": sum(w.run == k for w in d.windows_after)})
    return rows


def _outcome(t: Trial) -> str:
    """Why a tested candidate was not named, with the evidence it had and needed."""
    if t.rejected_because:
        return t.rejected_because
    if t.delta_bic >= -BIC_MARGIN:
        return f"the training runs do not support it (delta BIC {t.delta_bic:+.1f}, below -{BIC_MARGIN:g} needed)"
    if t.held_out_needed is not None and t.held_out_evidence < t.held_out_needed:
        return (f"the held-out runs do not support it (log-likelihood evidence {t.held_out_evidence:+.1f}, "
                f"{t.held_out_needed:.1f} needed)")
    return "another candidate explained the same rows better"


def tested_across_runs(d: Diagnosis) -> list[dict]:
    """The candidates of a campaign that only some training runs can show (the runs whose hall air moved, whose
    speeds span a threshold), tested and not named: which runs carried the test, the air they ran in, and the
    evidence it had against what it needed. Candidates listed as supported but not named are said there."""
    parts = d.parts
    if not parts.campaign:
        return []
    named = {e["name"] for e in d.added} | {e["name"] for e in d.unsupported}
    last = {t.name: t for trials in d.rounds for t in trials if t.sensor is None}
    training = [k for k, rows in enumerate(parts.train_rows) if rows > 0]
    entries = []
    for name, t in last.items():
        showing = showing_run_indexes(parts, name)
        if name in named or not showing or showing == training:
            continue
        air = np.concatenate([parts.runs[k].te[:parts.train_rows[k]] for k in showing])
        entries.append({"name": name, "shown_by_runs": [run_label(parts, k) for k in showing],
                        "air_C": [float(air.min()), float(air.max())], "delta_bic": t.delta_bic,
                        "held_out_evidence": t.held_out_evidence, "held_out_needed": t.held_out_needed,
                        "why_not_named": _outcome(t)})
    return entries


def document(d: Diagnosis, source: dict, model_path: str | None) -> dict:
    """The findings document (findings.json) as a dict: verdict and summary, the effects named, the disagreement
    windows before and after, and each channel's training and held-out errors (um for the target, else K)."""
    target = d.channels[-1]
    channels = {c: {"unit": "um" if c == target else "K", "noise_sigma": d.sigma[c],
                    "train_rmse_before": d.before.rmse_train[c], "train_rmse_after": d.after.rmse_train[c],
                    "held_out_rmse_before": d.before.rmse_held_out[c], "held_out_rmse_after": d.after.rmse_held_out[c],
                    "held_out_max_abs_before": d.before.max_abs_held_out[c],
                    "held_out_max_abs_after": d.after.max_abs_held_out[c],
                    "open_loop_held_out_rmse_before": rms(d.residual_before[c][d.parts.n_train:]),
                    "open_loop_held_out_rmse_after": rms(d.residual_after[c][d.parts.n_train:])}
                for c in d.channels}
    return {
        "format": FORMAT,
        "version": VERSION,
        "data": {**source, "rows": d.parts.rows, "train_rows": d.parts.n_train, "sample_period_s": d.parts.runs[0].dt},
        "runs": per_run(d),
        "verdict": d.verdict,
        "summary": summary(d),
        "reason": d.reason,
        "effects": d.named,
        "fitted_not_named": [] if d.names_effects else [e["name"] for e in d.added],
        "supported_not_named": d.unsupported,
        "tested_across_runs": tested_across_runs(d),
        "disagreements": [_window(w, d, True) for w in d.windows_before],
        "remaining_disagreements": [_window(w, d, False) for w in d.windows_after],
        "rmse_before_um": d.before.rmse_held_out[target],
        "no_compensation_rmse_um": sufficiency.no_compensation_rmse(d.parts),
        "rmse_after_um": d.after.rmse_held_out[target],
        "max_abs_before_um": d.before.max_abs_held_out[target],
        "max_abs_after_um": d.after.max_abs_held_out[target],
        "channels": channels,
        "tested": [[vars(t) for t in trials] for trials in d.rounds],
        "not_tested": d.not_tested,
        "ambiguous": list(d.ambiguous),
        "model": model_path,
    }


def summary(d: Diagnosis) -> str:
    """The verdict as one short sentence for people: what was named and how many disagreement windows are left (why
    is the document's `reason`, said on its own line)."""
    if d.verdict == "insufficient_data":
        return "the data cannot decide"
    if d.verdict == "no_missing_effect":
        return "no significant missing effect: simulation and measurement agree within the noise on every channel"
    names = ", ".join(e["name"] for e in d.named)
    left = len(d.windows_after)
    if d.verdict == "explained":
        return f"explained by {names}; no disagreement beyond the noise is left"
    if d.ambiguous:
        return (f"{left} disagreement window(s) left; " + " or ".join(d.ambiguous) + " would fit, but the data cannot "
                f"tell which")
    found = f"found {names}, but " if names else ""
    return f"{found}{left} disagreement window(s) not explained by any known effect"


def _um(value: float | None) -> str:
    return "an unmeasured amount" if value is None else f"{value:.3g} um"


def percent(share: float) -> str:
    """A share in whole percent; a share that rounds to nothing is 0 %, never "-0%"."""
    return f"{round(share, 2) + 0.0:.0%}"


def display(value, braces: bool = True) -> str:
    """A parameter or evidence value for people: 4 significant digits, dicts as key: value
    (in braces for the text output, bare in the HTML table's cells)."""
    if isinstance(value, dict):
        inner = ", ".join(f"{k}: {display(v, braces)}" for k, v in value.items())
        return "{" + inner + "}" if braces else inner
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, list):
        return " .. ".join(display(v, braces) for v in value)
    return "" if value is None else str(value)


VERDICT_WIDTH = 200  # the verdict line reads at a glance; the details follow, each once


def text(doc: dict) -> str:
    """The console report of findings document `doc`: verdict, each named effect with its evidence, the channels'
    held-out errors before and after, and the commands to run next."""
    head = f"verdict: {doc['verdict']} - {doc['summary']}"
    lines = [head if len(head) <= VERDICT_WIDTH else head[:VERDICT_WIDTH - 4].rsplit(" ", 1)[0] + " ..."]
    if doc.get("reason"):
        lines.append(f"  why: {doc['reason']}")
    for k, e in enumerate(doc["effects"], start=1):
        ev = e["evidence"]
        lines.append(f"  {k}. {e['name']}: {display(e['parameters'])}")
        if e.get("shown_by_runs"):
            runs = e["shown_by_runs"]
            lines.append(f"     shown by the training run{'s' if len(runs) > 1 else ''} {', '.join(runs)}"
                         + (" (each alone)" if len(runs) > 1 else ""))
        lines.append(f"     delta BIC {ev['delta_bic']:.1f}; held-out log-likelihood evidence {ev['held_out_evidence']:+.1f}; "
                     f"held-out excess above noise removed {percent(ev['held_out_excess_removed'])}")
        if ev.get("held_out_size_um") is not None:
            lines.append(f"     held out: moves the target {ev['held_out_size_um']:.3g} um (RMS), removes "
                         f"{percent(ev['held_out_error_removed'])} of its squared error; {e['matters']} "
                         f"({doc['rmse_after_um']:.3g} um left)")
    for e in doc.get("supported_not_named", []):
        ev = e["evidence"]
        lines.append(f"  not named: {e['name']}" + (f" on {e['sensor']}" if e.get("sensor") else "")
                     + f" (delta BIC {ev['delta_bic']:.1f}; held out it moves the target {_um(ev['held_out_size_um'])}, "
                       f"{e['matters']}; {e['why_not_named']})")
    for e in doc.get("tested_across_runs", []):
        runs, (low, high) = e["shown_by_runs"], e["air_C"]
        needed = "" if e["held_out_needed"] is None else f", {e['held_out_needed']:.1f} needed"
        lines.append(f"  not named: {e['name']}, tested over the training run{'s' if len(runs) > 1 else ''} "
                     f"{', '.join(runs)} (air {low:.1f}..{high:.1f} degC; delta BIC {e['delta_bic']:.1f}; held-out "
                     f"evidence {e['held_out_evidence']:+.1f}{needed}): {e['why_not_named']}")
    lines.append(f"  disagreement windows: {len(doc['disagreements'])} before, {len(doc['remaining_disagreements'])} after")
    lines.append(f"  {'held out':<31}{'judged RMSE (one step)':>22}{'open-loop RMSE':>20}{'max (judged)':>20}")
    lines.append(f"  {'channel':<16}{'unit':<6}{'noise':>9}{'before':>12}{'after':>10}{'before':>10}{'after':>10}"
                 f"{'before':>10}{'after':>10}")
    for c, v in doc["channels"].items():
        if v["held_out_rmse_before"] is None:
            continue
        lines.append(f"  {c:<16}{v['unit']:<6}{v['noise_sigma']:>9.3g}{v['held_out_rmse_before']:>12.3f}"
                     f"{v['held_out_rmse_after']:>10.3f}{v['open_loop_held_out_rmse_before']:>10.3f}"
                     f"{v['open_loop_held_out_rmse_after']:>10.3f}{v['held_out_max_abs_before']:>10.3f}"
                     f"{v['held_out_max_abs_after']:>10.3f}")
    if doc.get("no_compensation_rmse_um") is not None:
        lines.append(f"  no compensation: held-out RMSE {doc['no_compensation_rmse_um']:.3f} um")
    if len(doc["runs"]) > 1:
        lines += _runs_table(doc["runs"])
    if doc["not_tested"]:
        lines.append("  not tested: " + "; ".join(f"{k} ({v})" for k, v in doc["not_tested"].items()))
    steps = next_steps(doc)
    if steps:
        lines += ["next:", *(f"  {command}" for command in steps)]
    return "\n".join(lines)


def _runs_table(runs: list[dict]) -> list[str]:
    """A campaign's target RMSE per run before and after, each run with its role and the hall air it ran in."""
    lines = [f"  {'run':<24}{'role':<10}{'air degC':>12}{'RMSE before':>13}{'after':>8}"]
    for r in runs:
        held = r["role"] == "held out"
        before, after = ((r["held_out_rmse_before_um"], r["held_out_rmse_after_um"]) if held else
                         (r["train_rmse_before_um"], r["train_rmse_after_um"]))
        low, high = r["ambient_C"]
        name = r["run"] if len(r["run"]) <= 23 else ".." + r["run"][-21:]  # the end tells runs apart
        lines.append(f"  {name:<24}{r['role']:<10}{f'{low:.1f}..{high:.1f}':>12}{before:>13.3f}{after:>8.3f}")
    return lines


def next_steps(doc: dict) -> list[str]:
    """The commands that turn the diagnosed model into a proven block, as the user would type them."""
    model, data = doc.get("model"), doc["data"].get("file")
    if not model or doc.get("verdict") == "insufficient_data":  # the data could not judge it: no block to prove
        return []
    block = _argument(str(Path(model).with_suffix(".scl")))
    runs = doc["data"].get("given", [])  # a campaign as the command was given it: --data ... or --runs TABLE
    verify = (f"thermoplc verify {block} --model {_argument(model)}" + (f" --data {_argument(data)}" if data else "")
              + "".join(f" {option} {_argument(value)}" for option, value in runs))
    return [f"thermoplc generate {_argument(model)} -o {block}", verify]


def _argument(path: str) -> str:
    """A path as a shell argument the command cannot take for an option ('-x.json' as './-x.json')."""
    return shlex.quote(f"./{path}" if path.startswith("-") else path)
