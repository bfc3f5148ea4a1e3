"""The diagnosis report: one HTML page with PNG plots beside it, readable offline."""
from __future__ import annotations

import html
import io
import re

import numpy as np

from thermoplc.diagnosis.search import Diagnosis
from thermoplc.diagnosis.findings import display, next_steps, percent
from thermoplc.diagnosis.windows import SMOOTHING_S, rms as measured_rms, smooth, smoothing_rows


def _unit(channel: str, target: str) -> str:
    """Temperatures in degC (their residuals in K), the displacement in um."""
    return "um" if channel == target else "degC"


def _plot(d: Diagnosis, run: int, channel: str, measured: np.ndarray, unit: str) -> bytes:
    """One channel of one run, as an engineer compares it with the measurement: measured (and, noisy, its
    average over the windows' smoothing time) beside the simulation before and after; the residuals averaged
    the same way with the disagreement windows shaded; what the named effects add to the simulation on its own
    axis; the spindle speed beneath. The title gives the held-out RMSE before and after."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    parts = d.parts
    series, n_train = parts.runs[run], parts.train_rows[run]
    of_run = lambda pooled: parts.unpool(pooled)[run]
    hours = (series.t - series.t[0]) / 3600
    width = smoothing_rows(series.dt)
    difference = "um" if unit == "um" else "K"
    before, after = of_run(d.simulated_before[channel]), of_run(d.simulated_after[channel])
    residual_before, residual_after = of_run(d.residual_before[channel]), of_run(d.residual_after[channel])
    fig, (top, middle, effect, speed) = plt.subplots(4, 1, figsize=(11, 8.5), sharex=True,
                                                      gridspec_kw={"height_ratios": [3, 2, 1.2, 1]})
    probed = not np.isfinite(measured).all()  # a probed target: its probings as points
    if probed:
        top.plot(hours, measured, ls="none", marker=".", ms=4, color="black", label="probings", zorder=7)
    else:
        top.plot(hours, measured, lw=0.5, color="0.6", label="measured", zorder=1)
    top.plot(hours, smooth(measured, width), lw=1.2, color="black",
             label=f"measured, {SMOOTHING_S / 60:g} min average", zorder=4)
    top.plot(hours, before, lw=1.2, color="tab:red", ls="--", label="simulation before", zorder=5)
    top.plot(hours, after, lw=1.2, color="tab:blue", ls="--", label="simulation after", zorder=6)
    top.set_ylabel(f"{channel}, {unit}")
    top.legend(loc="upper left", fontsize=9, ncol=2)
    for residual, colour, label in ((residual_before, "tab:red", "before"), (residual_after, "tab:blue", "after")):
        middle.plot(hours, residual, **({"ls": "none", "marker": ".", "ms": 3} if probed else {"lw": 0.4}),
                    color=colour, alpha=0.25)
        middle.plot(hours, smooth(residual, width), lw=1.2, color=colour,
                    label=f"residual {label}, {SMOOTHING_S / 60:g} min average")
    for w in d.windows_before:
        if w.channel == channel and w.run == run:
            middle.axvspan(hours[w.start], hours[w.stop - 1], color="orange", alpha=0.25, lw=0)
    middle.axhline(0.0, color="k", lw=0.6)
    middle.set_ylabel(f"measured - simulated, {difference}")
    middle.legend(loc="upper left", fontsize=9)
    effect.plot(hours, after - before, lw=1.2, color="tab:green")
    effect.set_ylabel(f"named effects, {difference}", fontsize=9)
    effect.set_title("what the named effects add to the simulation (after - before)", fontsize=9, loc="left")
    speed.plot(hours, series.n, lw=0.8, color="0.3")
    speed.set_ylabel("speed, rpm", fontsize=9)
    speed.set_xlabel("time, h (dotted: end of the training part; shaded: disagreement windows)")
    for ax in (top, middle, effect, speed):
        if 0 < n_train < series.rows:
            ax.axvline(hours[n_train - 1], color="k", lw=0.8, ls=":")
        ax.grid(alpha=0.3)
    held = slice(n_train, None) if n_train < series.rows else slice(None)
    def rms(residual: np.ndarray) -> float:  # a held-out run never probed: nan, as its title says
        found = measured_rms(residual[held])
        return float("nan") if found is None else found
    where = "held-out" if n_train < series.rows else "training run"
    name = f"{parts.labels[run]}: " if parts.campaign else ""
    top.set_title(f"{name}{channel}: simulation RMSE on the {where} rows {rms(residual_before):.3g} {difference} "
                  f"before, {rms(residual_after):.3g} after", fontsize=11)
    return png_bytes(fig, 150)


def png_bytes(fig, dpi: int) -> bytes:
    """The figure as PNG bytes without a software stamp (the same bytes for the same data), then closed."""
    import matplotlib.pyplot as plt
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi, metadata={"Software": None})
    plt.close(fig)
    return buffer.getvalue()


def html_table(header: list[str], rows: list[list]) -> str:
    """An HTML table of escaped cells (floats to 4 significant digits, booleans yes/no): the reports' tables."""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(_cell(v))}</td>" for v in row) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _cell(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    return display(v, braces=False)


def _percent(share) -> str:
    return "" if share is None else percent(share)


def _number(value, digits: int = 3) -> str:
    return "" if value is None else f"{value:.{digits}f}"


def _conditions(found: dict, unit: str) -> str:
    """A window's operating conditions in an engineer's words and units."""
    span = lambda pair, digits: f"{pair[0]:.{digits}f}..{pair[1]:.{digits}f}"
    parts = [f"speed {span(found['speed_rpm'], 0)} rpm", f"spindle {found['spindle']}",
             f"ambient {span(found['ambient_C'], 2)} degC", f"{span(found['hours_since_start'], 2)} h from the start",
             f"measured - simulated {found['measured_minus_simulated_mean']:+.3f} {unit} on average"]
    if "feed_mm_min" in found:
        parts.append(f"feed {span(found['feed_mm_min'], 0)} mm/min")
    return "; ".join(parts)


def _hours(seconds) -> str:
    return "" if seconds is None else f"{seconds / 3600:.2f}"


def report_files(channels: int, runs: int = 1) -> list[str]:
    """The files a report of this many channels and runs consists of (its manifest lists them): a plot per
    channel of one recording, a plot per run of a campaign."""
    plots = (f"channel_{k}.png" for k in range(1, channels + 1)) if runs == 1 else (f"run_{k}.png"
                                                                                   for k in range(1, runs + 1))
    return [*plots, "index.html"]


def is_report_file(name: str) -> bool:
    """Named as a report of any number of channels names its files: only such a file of an older
    report is removed when a new one leaves it out."""
    return name == "index.html" or re.fullmatch(r"(channel|run)_[1-9][0-9]*\.png", name) is not None


def _figures(d: Diagnosis) -> tuple[dict, list[str]]:
    """One PNG per channel for a recording; for a campaign one per run, of the target (where the gap was in
    each run and how it shrank)."""
    parts, target = d.parts, d.channels[-1]
    files, figures = {}, []
    if not parts.campaign:
        series = parts.runs[0]
        measured = {**{c: series.temps[:, i] for i, c in enumerate(series.names)}, target: series.target}
        for k, channel in enumerate(d.channels, start=1):
            name = f"channel_{k}.png"
            files[name] = _plot(d, 0, channel, measured[channel], _unit(channel, target))
            figures.append(f'<h3>{html.escape(channel)}</h3><img src="{name}" alt="{html.escape(channel)}">')
        return files, figures
    for k, (series, label) in enumerate(zip(parts.runs, parts.labels), start=1):
        name = f"run_{k}.png"
        files[name] = _plot(d, k - 1, target, series.target, "um")
        figures.append(f'<h3>{html.escape(label)}</h3><img src="{name}" alt="{html.escape(label)}">')
    return files, figures


def report(doc: dict, d: Diagnosis) -> dict:
    """File name -> content: index.html and the PNGs (`_figures`)."""
    target = d.channels[-1]
    parts = d.parts
    files, figures = _figures(d)
    effects = html_table(["#", "effect", "parameters", "delta BIC", "held-out evidence",
                          "held-out excess above noise removed",
                          "held-out size um", "held-out squared error removed", "against the misfit left"],
                     [[k, e["name"], e["parameters"], _number(e["evidence"]["delta_bic"], 1),
                       _number(e["evidence"]["held_out_evidence"], 1),
                       _percent(e["evidence"]["held_out_excess_removed"]),
                       _number(e["evidence"].get("held_out_size_um"), 3),
                       _percent(e["evidence"].get("held_out_error_removed")), e.get("matters", "")]
                      for k, e in enumerate(doc["effects"], start=1)] or [["", "none", "", "", "", "", "", "", ""]])

    def gap(c: str) -> str:
        return "um" if c == target else "K"
    channels = html_table(["channel", "unit", "noise", "held-out RMSE before", "after", "max |residual| before", "after"],
                      [[c, gap(c), _number(v["noise_sigma"]), _number(v["held_out_rmse_before"]),
                        _number(v["held_out_rmse_after"]), _number(v["held_out_max_abs_before"]),
                        _number(v["held_out_max_abs_after"])] for c, v in doc["channels"].items()])
    windows = html_table(["run", "channel", "start, h from the run's first row", "end, h", "unit", "RMS before",
                          "RMS after", "conditions"],
                     [[w.get("run", ""), w["channel"], _hours(w["conditions"]["hours_since_start"][0] * 3600),
                       _hours(w["conditions"]["hours_since_start"][1] * 3600),
                       gap(w["channel"]), _number(w["rms"]), _number(w.get("rms_after")),
                       _conditions(w["conditions"], gap(w["channel"]))]
                      for w in doc["disagreements"]])
    trials = "".join(f"<h3>round {k}</h3>" + html_table(["candidate", "sensor", "delta BIC", "held-out evidence",
                                                     "held-out excess removed", "kept", "implausible because"],
                                                    [[t["name"], t["sensor"], _number(t["delta_bic"], 1),
                                                      _number(t["held_out_evidence"], 1),
                                                      _percent(t["held_out_gain"]), bool(t["accepted"]),
                                                      t["rejected_because"]]
                                                     for t in trials])
                     for k, trials in enumerate(doc["tested"], start=1))
    runs = html_table(["run", "role", "rows", "air degC", "training RMSE before um", "after", "held-out RMSE before um",
                       "after", "windows before", "after"],
                      [[r["run"], r["role"], r["rows"], f"{r['ambient_C'][0]:.1f}..{r['ambient_C'][1]:.1f}",
                        _number(r["train_rmse_before_um"]),
                        _number(r["train_rmse_after_um"]), _number(r["held_out_rmse_before_um"]),
                        _number(r["held_out_rmse_after_um"]), r["windows_before"], r["windows_after"]]
                       for r in doc["runs"]])
    if parts.campaign:
        training = sum(k > 0 for k in parts.train_rows)
        data = (f"{len(parts.runs)} runs, {doc['data']['rows']} rows; {training} training runs "
                f"({parts.n_train} rows), {len(parts.runs) - training} held out")
    else:
        series = parts.runs[0]
        data = (f"{html.escape(str(doc['data'].get('file')))} ({doc['data']['rows']} rows, "
                f"{(series.t[-1] - series.t[0]) / 3600:.1f} h; training part {parts.n_train} rows, the first "
                f"{(series.t[parts.n_train - 1] - series.t[0]) / 3600:.1f} h)")
    not_named = (f"<p>Fitted but not named (disagreements are left after several effects; they may stand in for "
                 f"what is missing): {html.escape(', '.join(doc['fitted_not_named']))}</p>"
                 if doc["fitted_not_named"] else "")
    unsupported = doc.get("supported_not_named", [])
    if unsupported:
        not_named += ("<p>Supported by the training part, not by the held-out part (not named):</p>"
                      + html_table(["effect", "sensor", "delta BIC", "held-out size um", "against the misfit left",
                                    "why not named"],
                                   [[e["name"], e.get("sensor") or "", _number(e["evidence"]["delta_bic"], 1),
                                     _number(e["evidence"]["held_out_size_um"], 3), e["matters"], e["why_not_named"]]
                                    for e in unsupported]))
    across = doc.get("tested_across_runs", [])
    if across:
        not_named += ("<p>Tested over the training runs that can show it, not named:</p>"
                      + html_table(["effect", "shown by the training runs", "air degC", "delta BIC",
                                    "held-out evidence", "needed", "why not named"],
                                   [[e["name"], ", ".join(e["shown_by_runs"]),
                                     f"{e['air_C'][0]:.1f}..{e['air_C'][1]:.1f}", _number(e["delta_bic"], 1),
                                     _number(e["held_out_evidence"], 1), _number(e["held_out_needed"], 1),
                                     e["why_not_named"]] for e in across]))
    commands = next_steps(doc)
    next_section = ("<h2>What to run next</h2><p>Generate the block of the diagnosed model and prove it on the "
                    "recording:</p><pre>" + html.escape("\n".join(commands)) + "</pre>") if commands else ""
    page = f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>thermoplc diagnosis</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:auto}}table{{border-collapse:collapse;margin:8px 0}}
td,th{{border:1px solid #bbb;padding:3px 6px;font-size:13px;text-align:left}}img{{max-width:100%}}</style></head>
<body><h1>Where simulation and measurement disagree</h1>
<p>Data: {data}. Temperatures in degC and their residuals in K, the displacement in um.</p>
<h2>Verdict: {html.escape(doc['verdict'])}</h2><p>{html.escape(doc['summary'])}</p>
<h2>Effects named, in order</h2>{effects}{not_named}
<h2>Gap before and after (held-out part)</h2>{channels}
<h2>Per run: where the gap was and how it shrank (target)</h2>{runs}
<h2>Disagreement windows of the baseline</h2>{windows}
{next_section}<h2>Plots</h2>{''.join(figures)}
<h2>Candidates tested</h2>{trials}
</body></html>
"""
    files["index.html"] = page
    return files
