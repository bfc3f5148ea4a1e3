"""Issue 63 item 3: a fit report tells the truth at a glance. A fused run's title carries the figure the console
prints for it (the error just before each probing, not the output after the probing was absorbed, which is 0 by
construction); index.html opens with generate's verdict, holds the none/static/reset/fused table, and marks a run
the block predicts worse than no compensation."""
import html
import json
import re

import numpy as np
import pytest

from tests.cli_runner import thermoplc
from thermoplc.recordings.table import read_table, write_table

TEMPS = ("--temps", "T_motor,T_bearing")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("report")
    thermoplc("twin", "--runs", 6, "--hours", 4, "--dt", 60, "--seed", 3, "--probe-minutes", 30, "-o", "runs",
              cwd=folder)
    return folder


def _headings(page: str) -> list[str]:
    return [html.unescape(re.sub(r"<[^>]+>", "", h)) for h in re.findall(r"<h3[^>]*>(.*?)</h3>", page)]


def test_the_fused_report_titles_each_run_with_the_consoles_figure_just_before_each_probing(runs):
    out = thermoplc("fit", "--data", "runs", "--model", "mlr", "--target", "E_z_um", "--held-target", *TEMPS,
                    "--folds", 6, "--probe", "--report", "fused", "-o", "fused.json", cwd=runs).stdout
    console = {m.group(1): float(m.group(2)) for m in re.finditer(
        r"^  (run_\d{3}\.csv) +\d+ +[\d.]+ +[\d.]+ +[\d.]+ +([\d.]+)$", out, re.MULTILINE)}
    assert len(console) == 6
    page = (runs / "fused" / "index.html").read_text()
    titles = _headings(page)
    for title in titles:
        label = re.match(r"\d+\. (run_\d{3}\.csv): ", title).group(1)
        shown = float(re.search(r"fused block: RMSE ([\d.]+) µm \(just before each probing", title).group(1))
        assert shown == console[label] > 0.1, title
    assert "generate will write this block" in page or "generate will refuse this model" in page
    assert page.index("class='verdict") < page.index("<h2>")  # the verdict before anything else
    table = page[page.index("Probe fusion: no compensation, static block, plain reset and fused"):]
    assert "fused RMSE µm, just before each probing" in table and ">all runs<" in table
    assert sorted(p.name for p in (runs / "fused").glob("*.png")) == [
        *(f"run_{k:03d}.png" for k in range(1, 7)), "summary.png"]  # not run_001_run_001.png
    assert " um" not in re.sub(r"<pre>.*?</pre>", "", page, flags=re.DOTALL)  # µm outside the console text


def test_a_run_the_block_predicts_worse_than_no_compensation_is_marked(runs):
    planted = runs / "planted"
    planted.mkdir()
    for path in sorted((runs / "runs").glob("run_*.csv")):
        table = read_table(path, sparse=("E_z_um",))
        columns = dict(table.columns)
        if path.name == "run_003.csv":  # a run that hardly drifted: every prediction is an error
            columns["E_z_um"] = np.where(np.isfinite(columns["E_z_um"]), 0.02 * columns["E_z_um"], np.nan)
        (planted / path.name).write_text(write_table(columns))
    out = thermoplc("fit", "--data", "planted", "--model", "mlr", "--target", "E_z_um", "--held-target", *TEMPS,
                    "--folds", 6, "--report", "static", "-o", "static.json", cwd=runs).stdout
    runs_held = {r["run"]: r for r in json.loads((runs / "static.json").read_text())["metrics"]["runs"]}
    assert runs_held["run_003.csv"]["rmse"] > runs_held["run_003.csv"]["zero_rmse"]
    page = (runs / "static" / "index.html").read_text()
    worse = sorted(label for label, r in runs_held.items() if r["rmse"] > r["zero_rmse"])
    marked = [re.match(r"\d+\. (\S+):", t).group(1) for t in _headings(page) if "WORSE than no compensation" in t]
    assert marked == worse and "run_003.csv" in worse
    assert "class='worse'>3. run_003.csv" in page
    for label in worse:
        assert re.search(rf"<td>{re.escape(label)}</td>(?:(?!</tr>).)*<td>WORSE than no compensation</td>", page)
    assert f"On {len(worse)} of 6 runs the block does worse than no compensation" in page
    assert "wrote static/index.html" in out
