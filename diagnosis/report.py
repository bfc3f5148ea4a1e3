"""The diagnosis report: one HTML page with PNG plots beside it, readable offline."""
from __future__ import annotations

import html
import io
from pathlib import Path

import numpy as np

from thermoplc.diagnosis.search import Diagnosis
from thermoplc.diagnosis.findings import display
from thermoplc.models.simulation import Series


def _plot(series: Series, d: Diagnosis, channel: str, measured: np.ndarray, n_train: int) -> bytes:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hours = (series.t - series.t[0]) / 3600
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    top.plot(hours, measured, lw=0.6, color="0.6", label="measured")
    top.plot(hours, d.simulated_before[channel], lw=1.0, color="tab:red", label="simulation before")
    top.plot(hours, d.simulated_after[channel], lw=1.0, color="tab:blue", label="simulation after")
    top.set_ylabel(channel)
    top.legend(loc="upper left", fontsize=8)
    bottom.plot(hours, d.residual_before[channel], lw=0.5, color="tab:red", label="residual before")
    bottom.plot(hours, d.residual_after[channel], lw=0.5, color="tab:blue", label="residual after")
    for w in d.windows_before:
        if w.channel == channel:
            bottom.axvspan(hours[w.start], hours[w.stop - 1], color="orange", alpha=0.25, lw=0)
    for ax in (top, bottom):
        ax.axvline(hours[n_train - 1], color="k", lw=0.8, ls="--")
    bottom.set_xlabel("hours (dashed: end of the training part; shaded: disagreement windows)")
    bottom.set_ylabel("measured - simulated")
    bottom.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90, metadata={"Software": None})
    plt.close(fig)
    return buffer.getvalue()


def _table(header: list[str], rows: list[list]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(_cell(v))}</td>" for v in row) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _cell(v) -> str:
    return display(v, braces=False)


def report_files(channels: int) -> list[str]:
    """The files a report of this many channels consists of (its manifest lists them)."""
    return [*(f"channel_{k}.png" for k in range(1, channels + 1)), "index.html"]


def report(doc: dict, d: Diagnosis, series: Series, n_train: int) -> dict:
    """File name -> content: index.html and one PNG per channel."""
    measured = {c: series.temps[:, i] for i, c in enumerate(series.names)}
    measured[d.channels[-1]] = series.target
    files, figures = {}, []
    for k, channel in enumerate(d.channels, start=1):
        name = f"channel_{k}.png"
        files[name] = _plot(series, d, channel, measured[channel], n_train)
        figures.append(f'<h3>{html.escape(channel)}</h3><img src="{name}" alt="{html.escape(channel)}">')
    effects = _table(["#", "effect", "parameters", "delta BIC", "held-out excess removed"],
                     [[k, e["name"], e["parameters"], e["evidence"]["delta_bic"], e["evidence"]["held_out_excess_removed"]]
                      for k, e in enumerate(doc["effects"], start=1)])
    channels = _table(["channel", "noise", "held-out RMSE before", "after", "max |residual| before", "after"],
                      [[c, v["noise_sigma"], v["held_out_rmse_before"], v["held_out_rmse_after"],
                        v["held_out_max_abs_before"], v["held_out_max_abs_after"]] for c, v in doc["channels"].items()])
    windows = _table(["channel", "start s", "end s", "RMS before", "RMS after", "conditions"],
                     [[w["channel"], w["start_s"], w["end_s"], w["rms"], w["rms_after"], w["conditions"]]
                      for w in doc["disagreements"]])
    trials = "".join(f"<h3>round {k}</h3>" + _table(["candidate", "sensor", "delta BIC", "held-out gain", "kept", "implausible"],
                                                    [[t["name"], t["sensor"], t["delta_bic"], t["held_out_gain"], t["accepted"],
                                                      t["rejected_because"]]
                                                     for t in trials])
                     for k, trials in enumerate(doc["tested"], start=1))
    page = f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>thermoplc diagnosis</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:auto}}table{{border-collapse:collapse;margin:8px 0}}
td,th{{border:1px solid #bbb;padding:3px 6px;font-size:13px;text-align:left}}img{{max-width:100%}}</style></head>
<body><h1>Where simulation and measurement disagree</h1>
<p>Data: {html.escape(str(doc['data'].get('file')))} ({doc['data']['rows']} rows, training part {n_train} rows).</p>
<h2>Verdict: {html.escape(doc['verdict'])}</h2><p>{html.escape(doc['summary'])}</p>
<h2>Effects added, in order</h2>{effects}
<h2>Gap before and after (held-out part)</h2>{channels}
<h2>Disagreement windows of the baseline</h2>{windows}
<h2>Plots</h2>{''.join(figures)}
<h2>Candidates tested</h2>{trials}
</body></html>
"""
    files["index.html"] = page
    return files
