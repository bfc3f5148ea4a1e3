"""Regenerate the golden blocks in tests/golden/ so a generator change shows up as a reviewable diff.

    python scripts/regen_golden.py          # re-render every <model>.scl from the committed <model>.json
    python scripts/regen_golden.py --refit  # also refit the model files on the golden twin data first
    python scripts/regen_golden.py --refit lumped  # ... only these kinds
    python scripts/regen_golden.py --envelope  # measure each committed model's envelope and plausibility anew
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import argparse
import json
import sys
from dataclasses import replace
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.golden_models import (  # noqa: E402
    DIALECTS, FUSED, FUSED_EVERY, GOLDEN, KINDS, batch_csvs, golden_bench, golden_block, golden_twin_csv, rendered,
    rendered_bench,
)
from thermoplc.diagnosis.command import augmented_model  # noqa: E402
from thermoplc.diagnosis.runs import DiagnoseRequest, series_of  # noqa: E402
from thermoplc.physics import simulation  # noqa: E402
from thermoplc.fitting.envelope_fit import measure_envelope  # noqa: E402
from thermoplc.fitting.plausibility_fit import fit_plausibility  # noqa: E402
from thermoplc.fitting.fit import FitRequest, fit, sample_period  # noqa: E402
from thermoplc.models.modelfile import load_model  # noqa: E402
from thermoplc.models.model import Model  # noqa: E402
from thermoplc.models.probing import Fusion  # noqa: E402
from thermoplc.recordings.table import read_table  # noqa: E402

# golden name -> the model kind `fit` writes for it: the identified baseline `fit --model lumped` writes
# (filtered by the readings) beside the open-loop block with every effect diagnose can add
FIT_KIND = {"lumped_identified": "lumped"}
# the lumped golden block carries every effect, so every branch of its lowering is under review
LUMPED_EFFECTS = (("gear_ratio_switch", None), ("nonlinear_speed_heat", None), ("stop_convection", None),
                  ("sensor_offset", 1), ("coolant_switching", 0), ("slow_structure", None), ("ambient_coupling", None),
                  ("feed_axis_heat", None))

GOLDEN_GEAR_LAG_S = 1200.0
GOLDEN_COOL_LAG_S = 600.0


def lumped_golden(path: Path) -> Model:
    request = DiagnoseRequest((str(path),), ("T_motor", "T_bearing"), "n_rpm", "T_env", "E_z_um", "v_feed_mm_min")
    table = read_table(path)
    series = series_of(table, request, sample_period(table, "time_s"))
    rows = int(np.searchsorted(table.columns["time_s"], 6 * 3600.0, side="right"))
    fitted = simulation.fit(series.head(rows), LUMPED_EFFECTS)
    if not fitted.shared.gear_tau_s:  # the twin's gear heats at once; the lag's branch is under review all the same
        fitted = replace(fitted, shared=replace(fitted.shared, gear_tau_s=GOLDEN_GEAR_LAG_S))
    if not fitted.shared.cool_tau_s:  # so does its coolant: the cooling lag's branch too
        fitted = replace(fitted, shared=replace(fitted.shared, cool_tau_s=GOLDEN_COOL_LAG_S))
    return augmented_model(fitted, [], request, [table], series.dt, (rows,))


def refit(folder: Path, kinds: tuple[str, ...]) -> None:
    table = read_table(golden_twin_csv(folder))
    batches = [read_table(p) for p in batch_csvs(folder)]
    for kind in kinds:
        if kind == "lumped":
            (GOLDEN / "lumped.json").write_text(lumped_golden(Path(table.path)).to_json())
            continue
        bpnn = kind == "bpnn"
        request = FitRequest(FIT_KIND.get(kind, kind), "E_z_um", ("T_motor", "T_bearing"), "n_rpm", "T_env", train_until=6 * 3600.0,
                             settings={"seed": 1, "population": 20, "generations": 10,
                                       **({"tool_length": "tool_length_mm"} if bpnn else {})},
                             extra_targets=("yaw_urad", "pitch_urad") if bpnn else ())
        tables = batches if kind == "piecewise" else [table]
        (GOLDEN / f"{kind}.json").write_text(fit(tables, request).to_json())
    for fused, kind in FUSED.items():  # the static golden with a fusion that keeps a rate and decays its offset
        model = load_model(GOLDEN / f"{kind}.json")
        probe = Fusion.of(0.7, 12.0, 100.0, 100.0, rate_gain=0.002, rate_max_um=0.05, decay=0.9999,
                          min_calls=FUSED_EVERY // 2)
        (GOLDEN / f"{fused}.json").write_text(replace(model, probe=probe).to_json())


def add_envelopes(folder: Path) -> None:
    """Each committed model file with the envelope of the runs it was fitted with (models/envelope.py) and the
    plausibility of its temperatures (models/plausibility.py), its coefficients untouched: a golden whose numbers
    were fitted by an older fit keeps them."""
    tables = {Path(p).name: read_table(p) for p in (golden_twin_csv(folder), *batch_csvs(folder))}
    for kind in (*KINDS, *FUSED):
        path = GOLDEN / f"{kind}.json"
        doc = json.loads(path.read_text())
        doc.pop("plausibility", None)  # refitted below: a section of an older rule need not load
        path.write_text(json.dumps(doc))
        model = load_model(path)
        record = model.training.get("batches", [model.training])
        runs = [tables[run["file"]] for run in record]
        trained = [int(run.get("rows", tables[run["file"]].rows)) for run in record]
        path.write_text(replace(model, envelope=measure_envelope(model, runs),
                                plausibility=fit_plausibility(model, runs, trained)).to_json())


def render_all() -> list[Path]:
    written = []
    for kind in (*KINDS, *FUSED):
        for dialect in (*DIALECTS, "plcopen"):
            path = golden_block(kind, dialect)
            path.write_text(rendered(kind, dialect))
            written.append(path)
    with tempfile.TemporaryDirectory() as tmp:
        for dialect in (*DIALECTS, "plcopen"):  # the test benches of the blocks just written
            path = golden_bench(dialect)
            path.write_text(rendered_bench(dialect, Path(tmp)))
            written.append(path)
    return written


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--refit", nargs="*", metavar="KIND", choices=KINDS,
                        help="refit the golden model files first (all, or these kinds)")
    parser.add_argument("--envelope", action="store_true",
                        help="measure each model file's training envelope anew (the default limits)")
    args = parser.parse_args()
    GOLDEN.mkdir(parents=True, exist_ok=True)
    if args.refit is not None:
        with tempfile.TemporaryDirectory() as tmp:
            refit(Path(tmp), tuple(args.refit) or KINDS)
    if args.envelope:
        with tempfile.TemporaryDirectory() as tmp:
            add_envelopes(Path(tmp))
    for path in render_all():
        print(f"wrote {path.relative_to(GOLDEN.parent.parent)}")


if __name__ == "__main__":
    main()
