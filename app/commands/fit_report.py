"""`fit --report DIR`: a campaign to look at, not 40 rows to read. One PNG per run (measured, the
held-out prediction of the fold that never saw the run, the model written, no compensation, and the
residual), the fold, run and group tables, and an index.html; written with the report machinery of
`diagnose --report` (base/fileio.py: a folder that is new, empty or our own, all files or none)."""
from __future__ import annotations

import html
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from thermoplc.base.fileio import REPORT_MANIFEST, report_manifest

INDEX = "index.html"
DPI = 150


def _png_name(k: int, path: str) -> str:
    """`run_001_<the recording's name>.png`: in table order, and named by the run (only letters, digits, '-', '_'
    and '.' of its name, at most 60: a hostile file name cannot leave the folder)."""
    stem = re.sub(r"[^A-Za-z0-9_.-]", "_", Path(str(path)).stem)[:60].strip(".") or "run"
    return f"run_{k + 1:03d}_{stem}.png"


def report_names(paths: list[str]) -> list[str]:
    """The files a report of the runs `paths` writes, its manifest aside."""
    return [INDEX, *(_png_name(k, p) for k, p in enumerate(paths))]


def is_report_file(name: str) -> bool:
    """Whether `name` is named as this report names its files (a stale one of an older report may go)."""
    return name == INDEX or (name.startswith("run_") and name.endswith(".png") and name[4:7].isdigit())


@dataclass(frozen=True)
class Scored:
    """A run's figures for its title and the index: the block's error and that of no compensation, on the rows
    that count (a single recording's held-out part; a campaign run whole, predicted by the fold without it)."""
    rmse: float
    none: float
    rows: str  # which rows: "held out" or "predicted by the fold without this run"


def _scored(measured: np.ndarray, predicted: np.ndarray, first: int, campaign: bool) -> Scored | None:
    counted = np.isfinite(measured) & (np.arange(len(measured)) >= first)
    if not counted.any():
        return None
    rms = lambda x: float(np.sqrt(np.mean(x[counted] ** 2)))
    return Scored(rms(measured - predicted), rms(measured), "fit without this run" if campaign else "held out")


def _plot(run, model, held_out: np.ndarray | None, written: np.ndarray, fused: tuple | None, first: int,
          score: Scored | None) -> bytes:
    """The run's figure; `fused` the fused block's output over the run and its probings (None: a static block)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    table = run.table
    hours = (table.columns[model.time_column] - table.columns[model.time_column][0]) / 3600
    measured = table.columns[model.target.column]
    taken = np.isfinite(measured)
    predicted = held_out if held_out is not None else written
    unit = model.target.unit
    with plt.rc_context({"font.size": 10, "legend.fontsize": 9}):
        fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True, height_ratios=(3, 2))
        attributes = ", ".join(f"{k} {v}" for k, v in run.attributes.items() if k not in ("file", "seed"))
        title = f"{run.name}" + (f" ({attributes})" if attributes else "")
        if score is not None:
            title += (f"\n{model.kind} {'fused ' if model.probe is not None else ''}block: RMSE {score.rmse:.2f} {unit} "
                      f"({score.rows}); no compensation "
                      f"{score.none:.2f} {unit}")
        fig.suptitle(title, fontsize=11)
        style = {"marker": "o", "ms": 3, "ls": "none"} if taken.sum() < 0.5 * len(taken) else {"lw": 1.0}
        top.plot(hours[taken], measured[taken], color="black", label="measured drift", **style)
        if held_out is not None:
            top.plot(hours, held_out, lw=1.2, color="tab:red", label="block's prediction, fit without this run")
        top.plot(hours, written, lw=1.0, color="tab:blue", ls="--", label="block's prediction, the model written")
        if fused is not None:
            predicted, probed = fused  # the block's output is the fused one
            top.plot(hours, predicted, lw=1.2, color="tab:green", label="fused with its probings")
            top.plot(hours[probed], measured[probed], "v", color="tab:green", ms=5, ls="none", label="probings")
        top.set_ylabel(f"{model.target.column}, {unit}")
        top.legend(loc="best")
        bottom.fill_between(hours[taken], measured[taken], 0.0, color="0.6", alpha=0.35, lw=0,
                            label="error with no compensation (the measured drift)")
        bottom.plot(hours[taken], (measured - predicted)[taken], color="tab:red", lw=1.0,
                    **({k: v for k, v in style.items() if k != "lw"}), label="error left with the block")
        bottom.axhline(0.0, color="grey", lw=0.8)
        bottom.set_ylabel(f"error on the part, {unit}")
        bottom.set_xlabel("time since the run's start, h")
        bottom.legend(loc="best")
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
            if 0 < first < len(hours):
                ax.axvline(hours[first], color="tab:purple", lw=1.2, ls=":")
        if 0 < first < len(hours):
            top.annotate("trained | held out", (hours[first], 1.0), xycoords=("data", "axes fraction"),
                         ha="center", va="bottom", fontsize=9, color="tab:purple")
        from thermoplc.diagnosis.report import png_bytes
        return png_bytes(fig, DPI)


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


def _page(model, campaign, pngs: list[str], scores: list, command: str) -> str:
    from thermoplc.commands.fit_summary import format_fit
    m = model.metrics
    inputs = ", ".join(f"{s.column} ({s.role})" for s in model.inputs)
    files = "".join(f"<li>{html.escape(run.table.path)} <small>sha256 {run.table.sha256[:16]}</small></li>"
                    for run in campaign.runs)
    refused = len(m.get("refused_runs", []))
    fitted = f"{len(campaign.runs) - refused} of " if refused else ""
    parts = [f"<h1>thermoplc fit: {html.escape(model.kind)} on {fitted}{len(campaign.runs)} run"
             f"{'s' if len(campaign.runs) != 1 else ''}" + (f" ({refused} refused for training)" if refused else "")
             + "</h1>",
             "<table class='what'>" + "".join(
                 f"<tr><th>{html.escape(k)}</th><td>{v}</td></tr>" for k, v in (
                     ("command", f"<code>{html.escape(command)}</code>"),
                     ("target", html.escape(f"{model.target.column} ({model.target.unit})")),
                     ("block inputs", html.escape(inputs)),
                     ("block", html.escape(f"{model.block_name}, model fingerprint {model.fingerprint()}")),
                     ("written by", html.escape(_version())))) + "</table>",
             f"<h2>Recordings</h2><ul>{files}</ul>"]
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
    for k, (label, png, score) in enumerate(zip(campaign.labels, pngs, scores), start=1):
        figures = (f": RMSE {score.rmse:.3f} {html.escape(model.target.unit)} ({score.rows}), no compensation "
                   f"{score.none:.3f}" if score is not None else "")
        parts.append(f'<h3>{k}. {html.escape(label)}{figures}</h3><img src="{png}" alt="{html.escape(label)}">')
    parts.append(f"<details><summary>console output</summary><pre>{html.escape(format_fit(model, campaign))}</pre>"
                 f"</details>")
    style = "body{font-family:sans-serif;max-width:1520px}table{border-collapse:collapse}td,th{border:1px solid #ccc;" \
            "padding:2px 6px;text-align:right}table.what td,table.what th{text-align:left}pre{font-size:12px}" \
            "img{max-width:100%}"
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>thermoplc fit: {html.escape(model.kind)}</title>"
            f"<style>{style}</style></head><body>{''.join(parts)}</body></html>\n")


def _version() -> str:
    from thermoplc.base.version import __version__
    return f"thermoplc {__version__}"


def report_files(folder: str, model, campaign, held_out: dict, command: str) -> list[tuple[Path, str | bytes]]:
    """The report's files, its manifest last, for the command to write with its other outputs (all or none)."""
    from thermoplc.models.reference import model_inputs, predict
    from dataclasses import replace
    files, pngs, scores = [], [], []
    trained = int(model.training.get("rows", 0)) if "batches" not in model.training else 0
    refused = {r["run"] for r in model.metrics.get("refused_runs", [])}  # fitting/broken_runs.py
    for k, (run, label) in enumerate(zip(campaign.runs, campaign.labels)):
        written = predict(model, model_inputs(model, run.table), "f64")[model.target.name]
        fold = held_out.get(run.table.path)
        first = 0 if fold is not None else trained
        measured = run.table.columns[model.target.column]
        output = fold if fold is not None else written
        fused = _fused(model, measured, output)
        score = _scored(measured, fused[0] if fused is not None else output, first, fold is not None)
        if score is not None and label in refused:
            score = replace(score, rows="refused for training: the model written, which never saw it")
        png = _png_name(k, run.table.path)
        files.append((Path(folder) / png, _plot(run, model, fold, written, fused, first, score)))
        pngs.append(png)
        scores.append(score)
    files.append((Path(folder) / INDEX, _page(model, campaign, pngs, scores, command)))
    files.append((Path(folder) / REPORT_MANIFEST, report_manifest([(Path(path).name, data) for path, data in files])))
    return files
