"""`fit --report DIR`: a campaign to look at, not 40 rows to read. One PNG per run (measured, the
held-out prediction of the fold that never saw the run, the model written, no compensation, and the
residual), the fold, run and group tables, and an index.html; written with the report machinery of
`diagnose --report` (base/fileio.py: a folder that is new, empty or our own, all files or none)."""
from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from thermoplc.base.fileio import REPORT_MANIFEST, report_manifest

INDEX = "index.html"


def _png_name(k: int) -> str:
    return f"run_{k + 1:03d}.png"


def report_names(runs: int) -> list[str]:
    """The files a report of `runs` runs writes, its manifest aside."""
    return [INDEX, *(_png_name(k) for k in range(runs))]


def is_report_file(name: str) -> bool:
    """Whether `name` is named as this report names its files (a stale one of an older report may go)."""
    return name == INDEX or (name.startswith("run_") and name.endswith(".png") and name[4:-4].isdigit())


def _plot(run, model, held_out: np.ndarray | None, written: np.ndarray) -> bytes:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    table = run.table
    hours = (table.columns[model.time_column] - table.columns[model.time_column][0]) / 3600
    measured = table.columns[model.target.column]
    taken = np.isfinite(measured)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    top.axhline(0.0, color="grey", lw=0.8, label="no compensation (0)")
    if held_out is not None:
        top.plot(hours, held_out, lw=1.0, color="tab:red", label="predicted, held out (fit without this run)")
    top.plot(hours, written, lw=1.0, color="tab:blue", ls="--", label="predicted by the model written")
    fused = _fused(model, measured, held_out if held_out is not None else written)
    if fused is not None:
        prediction, probed = fused
        top.plot(hours, prediction, lw=1.0, color="tab:green", label="fused with its probings (held out)")
        top.plot(hours[probed], measured[probed], "v", color="tab:green", ms=5, ls="none", label="probings")
    style = {"marker": "o", "ms": 3, "ls": "none"} if taken.sum() < 0.5 * len(taken) else {"lw": 0.8}
    top.plot(hours[taken], measured[taken], color="black", label="measured", **style)
    top.set_ylabel(f"{model.target.column}, um")
    top.legend(loc="best", fontsize=7)
    residual = measured - (held_out if held_out is not None else written)
    bottom.plot(hours[taken], residual[taken], color="tab:red", **style)
    bottom.axhline(0.0, color="grey", lw=0.8)
    bottom.set_ylabel("measured - predicted, um")
    bottom.set_xlabel(f"time since the run's start, h ({run.name})")
    for ax in (top, bottom):
        ax.grid(alpha=0.3)
    from thermoplc.diagnosis.report import png_bytes
    return png_bytes(fig, 80)


def _fused(model, measured: np.ndarray, static: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """A fused model's prediction over a run with the run's probings (its measured rows, or one every N calls
    as it was fitted), and where they were; None for a static model."""
    if model.probe is None:
        return None
    from thermoplc.models.probing import fuse, probings, rising
    value, new = probings(measured, model.metrics.get("probing", {}).get("every_calls"))
    return fuse(model.probe, np.asarray(static, float), value, new, "f64")["fused"], rising(new)


def _table(header: list[str], rows: list[list]) -> str:
    """The diagnosis report's table, the errors in um to 3 decimals as the console prints them."""
    from thermoplc.diagnosis.report import html_table
    return html_table(header, [[f"{v:.3f}" if isinstance(v, float) else v for v in row] for row in rows])


def _page(model, campaign, pngs: list[str]) -> str:
    from thermoplc.commands.fit_summary import format_fit
    m = model.metrics
    parts = [f"<h1>thermoplc fit: {html.escape(model.kind)} on {len(campaign.runs)} run"
             f"{'s' if len(campaign.runs) != 1 else ''}</h1>",
             f"<pre>{html.escape(format_fit(model, campaign))}</pre>"]
    if "cross_validation" in m:
        parts += ["<h2>Folds</h2>", _table(
            ["fold", "fitted rows", "rows predicted", "RMSE um", "max um", "none RMSE um", "none max um"],
            [[f["label"], f["train_rows"], f["rows"], f["rmse"], f["max_abs"], f["zero_rmse"], f["zero_max_abs"]]
             for f in m["cross_validation"]])]
    if m.get("runs"):
        attributes = dict(zip(campaign.labels, (run.attributes for run in campaign.runs)))
        parts += ["<h2>Runs, each predicted by the fold that never saw it</h2>", _table(
            ["run", "fold", *campaign.attributes, "rows measured", "RMSE um", "max um", "none RMSE um", "none max um"],
            [[r["run"], r["fold"], *(attributes.get(r["run"], {}).get(a, "") for a in campaign.attributes), r["rows"],
              r["rmse"], r["max_abs"], r["zero_rmse"], r["zero_max_abs"]] for r in m["runs"]])]
    if m.get("auto_ranking"):
        parts += ["<h2>auto: the candidates ranked</h2>", _table(
            ["kind", "sensors", "RMSE um", "max um", "ops/call", "note"],
            [[c["kind"], ",".join(c["sensors"]), c.get("rmse_um", ""), c.get("max_abs_um", ""),
              c.get("operations_per_call", ""), c.get("refused") or c.get("generate_refuses") or ""]
             for c in m["auto_ranking"]])]
    parts.append("<h2>Each run</h2>")
    parts += [f'<h3>{html.escape(label)}</h3><img src="{png}" alt="{html.escape(label)}">'
              for label, png in zip(campaign.labels, pngs)]
    style = "body{font-family:sans-serif;max-width:1000px}table{border-collapse:collapse}td,th{border:1px solid #ccc;" \
            "padding:2px 6px;text-align:right}pre{font-size:12px}"
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>thermoplc fit</title><style>{style}</style>"
            f"</head><body>{''.join(parts)}</body></html>\n")


def report_files(folder: str, model, campaign, held_out: dict) -> list[tuple[Path, str | bytes]]:
    """The report's files, its manifest last, for the command to write with its other outputs (all or none)."""
    from thermoplc.models.reference import model_inputs, predict
    files, pngs = [], []
    for k, run in enumerate(campaign.runs):
        written = predict(model, model_inputs(model, run.table), "f64")[model.target.name]
        files.append((Path(folder) / _png_name(k), _plot(run, model, held_out.get(run.table.path), written)))
        pngs.append(_png_name(k))
    files.append((Path(folder) / INDEX, _page(model, campaign, pngs)))
    files.append((Path(folder) / REPORT_MANIFEST, report_manifest([(Path(path).name, data) for path, data in files])))
    return files
