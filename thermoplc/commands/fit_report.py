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
from thermoplc.fitting.probe_fit import REFITTED

INDEX = "index.html"
SUMMARY = "summary.png"
DPI = 150


def _png_name(k: int, path: str) -> str:
    """`run_001_<the recording's name>.png` (`run_001.png` for a run named so): in table order, and named by the run
    (only letters, digits, '-', '_' and '.' of its name, at most 60: a hostile file name cannot leave the folder)."""
    stem = re.sub(r"[^A-Za-z0-9_.-]", "_", Path(str(path)).stem)[:60].strip(".") or "run"
    number = f"run_{k + 1:03d}"
    return f"{number}.png" if stem == number else f"{number}_{stem}.png"  # not run_001_run_001.png


def report_names(paths: list[str]) -> list[str]:
    """The files a report of the runs `paths` writes, its manifest aside."""
    return [INDEX, SUMMARY, *(_png_name(k, p) for k, p in enumerate(paths))]


def is_report_file(name: str) -> bool:
    """Whether `name` is named as this report names its files (a stale one of an older report may go)."""
    return name in (INDEX, SUMMARY) or (name.startswith("run_") and name.endswith(".png") and name[4:7].isdigit())


@dataclass(frozen=True)
class Scored:
    """A run's figures for its title and the index, as the console prints them: the block's error and that of no
    compensation on the rows that count (a single recording's held-out part; a campaign run whole, predicted by the
    fold without it; a fused block just before each probing, its fusion chosen without the run)."""
    rmse: float
    none: float
    rows: str  # which rows, and which fit
    beside: str = ""  # the other figures of a fused run: static, reset, every call

    @property
    def worse_than_none(self) -> bool:
        return self.rmse > self.none

    def title(self, kind: str, fused: bool, between: str = "; ") -> str:
        """The figures as the console prints them; `between` parts them (a line break under a figure)."""
        verdict = f"{between}WORSE than no compensation" if self.worse_than_none else ""
        return (f"{kind} {'fused ' if fused else ''}block: RMSE {self.rmse:.3f} µm ({self.rows}){between}no "
                f"compensation {self.none:.3f} µm{self.beside}{verdict}")


def _scored(measured: np.ndarray, predicted: np.ndarray, first: int, campaign: bool) -> Scored | None:
    counted = np.isfinite(measured) & (np.arange(len(measured)) >= first)
    if not counted.any():
        return None
    rms = lambda x: float(np.sqrt(np.mean(x[counted] ** 2)))
    return Scored(rms(measured - predicted), rms(measured), "fit without this run" if campaign else "held out")


def _probing_row(probing: dict, label: str) -> dict | None:
    """A run's line of the fit's probing evidence (one recording: its held-out part, the evidence)."""
    rows = {r["run"]: r for r in probing.get("runs", ())}
    return rows.get(label) or rows.get(f"{label} (held out)")


def _fused_scored(probing: dict, label: str) -> Scored | None:
    """A fused run's figures from the fit's probing evidence (metrics.probing, what the console prints): the error
    just before each probing, the worst moment for a part, and beside it the static block, the plain reset and,
    where the target is measured at every call, the fused error over every call."""
    row = _probing_row(probing, label)
    if row is None or row.get("fused_before_um") is None:
        return None
    every = (f", over every call {row['fused_rmse_um']:.3f}" if row.get("fused_rmse_um") is not None else "")
    how = "fusion chosen without this run" if probing.get("nested") else "held-out part"
    return Scored(row["fused_before_um"], row["none_before_um"], f"just before each probing, {how}",
                  f"; static {row['static_before_um']:.3f}, plain reset {row['reset_before_um']:.3f}{every}")


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
    with plt.rc_context({"font.size": 10, "legend.fontsize": 9}):
        fig, (top, bottom, inputs) = plt.subplots(3, 1, figsize=(10, 8.5), sharex=True, height_ratios=(3, 2, 2))
        attributes = ", ".join(f"{k} {v}" for k, v in run.attributes.items() if k not in ("file", "seed"))
        title = f"{run.name}" + (f" ({attributes})" if attributes else "")
        if score is not None:
            title += "\n" + score.title(model.kind, fused is not None, "\n")
        fig.suptitle(title, fontsize=10, color="tab:red" if score is not None and score.worse_than_none else "black")
        style = {"marker": "o", "ms": 3, "ls": "none"} if taken.sum() < 0.5 * len(taken) else {"lw": 1.0}
        top.plot(hours[taken], measured[taken], color="black", label="measured drift", **style)
        if held_out is not None:
            top.plot(hours, held_out, lw=1.2, color="tab:red", label="block's prediction, fit without this run")
        top.plot(hours, written, lw=1.0, color="tab:blue", ls="--", label="block's prediction, the model written")
        bottom.fill_between(hours[taken], measured[taken], 0.0, color="0.6", alpha=0.35, lw=0,
                            label="error with no compensation (the measured drift)")
        if fused is not None:
            output, before, probed = fused
            top.plot(hours, output, lw=1.2, color="tab:green", label="fused with its probings (the model written)")
            top.plot(hours[probed], measured[probed], "v", color="tab:green", ms=5, ls="none", label="probings")
            bottom.plot(hours[probed], (measured - before)[probed], "o", color="tab:green", ms=4,
                        label="fused error just before each probing (the model written)")
        refitted = model.metrics.get("probing", {}).get("static") == REFITTED and held_out is None
        bottom.plot(hours[taken], (measured - predicted)[taken], color="tab:red", lw=1.0,
                    **({k: v for k, v in style.items() if k != "lw"}),
                    label="error of the model written's static part (refitted for the fusion)" if refitted else
                    "static block's error")
        top.set_ylabel(f"{model.target.column}, µm")
        top.legend(loc="best")
        bottom.axhline(0.0, color="grey", lw=0.8)
        bottom.set_ylabel("error on the part, µm")
        bottom.legend(loc="best")
        _draw_inputs(inputs, hours, table, model)
        inputs.set_xlabel("time since the run's start, h")
        for ax in (top, bottom, inputs):
            ax.grid(alpha=0.3)
            if 0 < first < len(hours):
                ax.axvline(hours[first], color="tab:purple", lw=1.2, ls=":")
        if 0 < first < len(hours):
            top.annotate("trained | held out", (hours[first], 1.0), xycoords=("data", "axes fraction"),
                         ha="center", va="bottom", fontsize=9, color="tab:purple")
        from thermoplc.diagnosis.report import png_bytes
        return png_bytes(fig, DPI)


def _summary(labels: list[str], scores: list, model) -> bytes:
    """A bar per run and figure: no compensation beside the block (and, fused, the static block and the plain reset
    it holds as candidates), the figures of the titles: the runs worse than none stand out at a glance."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    shown = [(label, score) for label, score in zip(labels, scores) if score is not None]
    fused = model.probe is not None
    series = [("no compensation", [s.none for _, s in shown], "0.6")]
    if fused:
        row = lambda label: _probing_row(model.metrics.get("probing", {}), label) or {}
        series += [("static block", [row(label).get("static_before_um") or np.nan for label, _ in shown], "tab:red"),
                   ("plain reset", [row(label).get("reset_before_um") or np.nan for label, _ in shown], "tab:orange")]
    series.append(("fused block" if fused else f"{model.kind} block", [s.rmse for _, s in shown], "tab:green"))
    with plt.rc_context({"font.size": 10, "legend.fontsize": 9}):
        fig, ax = plt.subplots(figsize=(max(6.0, 0.9 * len(shown) + 2.5), 4.0))
        x = np.arange(len(shown))
        width = 0.8 / len(series)
        for k, (name, values, color) in enumerate(series):
            ax.bar(x + (k - (len(series) - 1) / 2) * width, values, width, label=name, color=color)
        ax.set_xticks(x, [label for label, _ in shown], rotation=30, ha="right")
        for tick, (_, score) in zip(ax.get_xticklabels(), shown):
            tick.set_color("tab:red" if score.worse_than_none else "black")
        ax.set_ylabel("RMSE, µm" + (" (just before each probing)" if fused else ""))
        ax.set_title("each run: the block beside no compensation (run names in red: worse than none)")
        ax.grid(axis="y", alpha=0.3)
        ax.legend(loc="best")
        from thermoplc.diagnosis.report import png_bytes
        return png_bytes(fig, DPI)


def _draw_inputs(ax, hours: np.ndarray, table, model) -> None:
    """The block's temperatures beneath the errors (what drove them), the speed on its own axis."""
    for signal in model.inputs:
        if "temperature" in signal.role or "ambient" in signal.role:
            ax.plot(hours, table.columns[signal.column], lw=0.9, label=signal.column)
    ax.set_ylabel("temperature, °C")
    speed = next((s for s in model.inputs if "speed" in s.role), None)
    if speed is not None:
        right = ax.twinx()
        right.plot(hours, table.columns[speed.column], lw=0.7, color="0.5", label=speed.column)
        right.set_ylabel(f"{speed.column}, rpm")
        right.legend(loc="upper right")
    ax.legend(loc="upper left", ncol=4)


def _fused(model, measured: np.ndarray, static: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """A fused model's output over a run with the run's probings (its measured rows, or one every N calls as it was
    fitted), its output just before each probing, and where they were; None for a static model."""
    if model.probe is None:
        return None
    from thermoplc.models.probing import fuse, probings, rising
    value, new = probings(measured, model.metrics.get("probing", {}).get("every_calls"))
    fused = fuse(model.probe, np.asarray(static, float), value, new, "f64")
    return fused["fused"], fused["before"], rising(new)


def _table(header: list[str], rows: list[list]) -> str:
    """The diagnosis report's table, the errors in µm to 3 decimals as the console prints them."""
    from thermoplc.diagnosis.report import html_table
    return html_table(header, [[f"{v:.3f}" if isinstance(v, float) else v for v in row] for row in rows])


def _verdict(model, refusal: str | None, scores: list) -> str:
    """The acceptance verdict first: what `generate` will do with this model file, and the runs worse than none."""
    worse = sum(1 for score in scores if score is not None and score.worse_than_none)
    runs = (f" On {worse} of {len(scores)} runs the block does worse than no compensation (marked below)."
            if worse else "")
    if refusal:
        said = re.sub(r"(\d) um\b", "\\1 µm", refusal)
        return (f"<p class='verdict refused'><b>generate will refuse this model:</b> {html.escape(said)}"
                f"{html.escape(runs)}</p>")
    return (f"<p class='verdict'><b>generate will write this block</b> ({html.escape(model.block_name)}): its held-out "
            f"evidence passes the acceptance rule.{html.escape(runs)}</p>")


def _probing_table(probing: dict) -> str:
    """None, static, plain reset and fused per run and over all runs, as the console prints them."""
    groups = [("before", "just before each probing")] + ([("rmse", "over every call")] if probing.get("full_rate") else [])
    header = ["run", "probings", *(f"{m} RMSE µm, {where}" for which, where in groups
                                   for m in ("none", "static", "reset", "fused"))]
    rows = [[row["run"], row["probings"], *(row[f"{m}_{which}_um"] for which, _ in groups
                                            for m in ("none", "static", "reset", "fused"))]
            for row in [*probing["runs"], {**probing["pooled"], "run": "all runs"}]]
    return "<h2>Probe fusion: no compensation, static block, plain reset and fused</h2>" + _table(header, rows)


def _page(model, campaign, pngs: list[str], scores: list, command: str, refusal: str | None) -> str:
    from thermoplc.commands.fit_summary import format_fit
    m = model.metrics
    inputs = ", ".join(f"{s.column} ({s.role})" for s in model.inputs)
    files = "".join(f"<li>{html.escape(run.table.path)} <small>sha256 {run.table.sha256[:16]}</small></li>"
                    for run in campaign.runs)
    refused = len(m.get("refused_runs", []))
    fitted = f"{len(campaign.runs) - refused} of " if refused else ""
    parts = [f"<h1>thermoplc fit: {html.escape(model.kind)} on {fitted}{len(campaign.runs)} run"
             f"{'s' if len(campaign.runs) != 1 else ''}" + (f" ({refused} refused for training)" if refused else "")
             + "</h1>", _verdict(model, refusal, scores),
             "<table class='what'>" + "".join(
                 f"<tr><th>{html.escape(k)}</th><td>{v}</td></tr>" for k, v in (
                     ("command", f"<code>{html.escape(command)}</code>"),
                     ("target", html.escape(f"{model.target.column} (µm)")),
                     ("block inputs", html.escape(inputs)),
                     ("block", html.escape(f"{model.block_name}, model fingerprint {model.fingerprint()}")),
                     ("written by", html.escape(_version())))) + "</table>",
             f"<h2>Recordings</h2><ul>{files}</ul>"]
    if "cross_validation" in m:
        parts += ["<h2>Folds</h2>", _table(
            ["fold", "fitted rows", "rows predicted", "RMSE µm", "max µm", "none RMSE µm", "none max µm"],
            [[f["label"], f["train_rows"], f["rows"], f["rmse"], f["max_abs"], f["zero_rmse"], f["zero_max_abs"]]
             for f in m["cross_validation"]])]
    if m.get("runs"):
        attributes = dict(zip(campaign.labels, (run.attributes for run in campaign.runs)))
        parts += ["<h2>Runs, each predicted by the fold that never saw it</h2>", _table(
            ["run", "fold", *campaign.attributes, "rows measured", "RMSE µm", "max µm", "none RMSE µm", "none max µm",
             "verdict"],
            [[r["run"], r["fold"], *(attributes.get(r["run"], {}).get(a, "") for a in campaign.attributes), r["rows"],
              r["rmse"], r["max_abs"], r["zero_rmse"], r["zero_max_abs"],
              "WORSE than no compensation" if r["rmse"] > r["zero_rmse"] else
              "no better than no compensation" if r["rmse"] == r["zero_rmse"] else "better"] for r in m["runs"]])]
    if m.get("probing"):
        parts += [_probing_table(m["probing"])]
    if m.get("auto_ranking"):
        parts += ["<h2>auto: the candidates ranked</h2>", _table(
            ["kind", "sensors", "RMSE um", "max um", "ops/call", "note"],
            [[c["kind"], ",".join(c["sensors"]), c.get("rmse_um", ""), c.get("max_abs_um", ""),
              c.get("operations_per_call", ""), c.get("refused") or c.get("generate_refuses") or ""]
             for c in m["auto_ranking"]])]
    parts.append(f'<h2>Each run</h2><img src="{SUMMARY}" alt="each run beside no compensation">')
    for k, (label, png, score) in enumerate(zip(campaign.labels, pngs, scores), start=1):
        figures = html.escape(": " + score.title(model.kind, model.probe is not None)) if score is not None else ""
        worse = " class='worse'" if score is not None and score.worse_than_none else ""
        parts.append(f'<h3{worse}>{k}. {html.escape(label)}{figures}</h3><img src="{png}" alt="{html.escape(label)}">')
    parts.append(f"<details><summary>console output</summary><pre>{html.escape(format_fit(model, campaign))}</pre>"
                 f"</details>")
    style = "body{font-family:sans-serif;max-width:1520px}table{border-collapse:collapse}td,th{border:1px solid #ccc;" \
            "padding:2px 6px;text-align:right}table.what td,table.what th{text-align:left}pre{font-size:12px}" \
            "img{max-width:100%}.worse{color:#b00}.verdict{font-size:18px;padding:6px;border:2px solid #2a2}" \
            ".verdict.refused{border-color:#b00}"
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>thermoplc fit: {html.escape(model.kind)}</title>"
            f"<style>{style}</style></head><body>{''.join(parts)}</body></html>\n")


def _version() -> str:
    from thermoplc.base.version import __version__
    return f"thermoplc {__version__}"


def report_files(folder: str, model, campaign, held_out: dict, command: str,
                 refusal: str | None) -> list[tuple[Path, str | bytes]]:
    """The report's files, its manifest last, for the command to write with its other outputs (all or none);
    `refusal`: why `generate` will refuse the model, or None."""
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
        score = (_fused_scored(model.metrics.get("probing", {}), label) if fused is not None else
                 _scored(measured, output, first, fold is not None))
        if score is not None and label in refused:
            score = replace(score, rows="refused for training: the model written, which never saw it")
        png = _png_name(k, run.table.path)
        files.append((Path(folder) / png, _plot(run, model, fold, written, fused, first, score)))
        pngs.append(png)
        scores.append(score)
    files.append((Path(folder) / SUMMARY, _summary(campaign.labels, scores, model)))
    files.append((Path(folder) / INDEX, _page(model, campaign, pngs, scores, command, refusal)))
    files.append((Path(folder) / REPORT_MANIFEST, report_manifest([(Path(path).name, data) for path, data in files])))
    return files
