"""`thermoplc demo`: the whole pipeline on the bundled FL_THERMAL recording (MIT, CAIVIAC 2024).

Sensor choice for displacement channel ch3, made on the first 24 h only (the training part):
- t5_C, the hottest sensor (29 -> 43 °C), stands for the spindle's heat source like paper 000's
  motor sensor;
- t1_C, the sensor whose rise correlates best with ch3 in the first 24 h (r = -0.81);
- ambient: t6_C, the sensor with the smallest spread in the first 24 h (1.3 K) that does not
  rise with spindle speed (r = -0.31) - the recording has no labelled ambient sensor.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

from thermoplc.base.version import __version__
from thermoplc.base.fileio import check_output, write_atomic
from thermoplc.fitting.acceptance import refusal
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.models.kinds import kind_of
from thermoplc.recordings.table import read_table
from thermoplc.pipeline import generate
from thermoplc.verifier.replays.replay import verify_against_model

TARGET = "ch3_um"
TEMPS = ("t5_C", "t1_C")
SPEED = "spindle_rpm"
AMBIENT = "t6_C"
TRAIN_UNTIL_S = 24 * 3600.0
BLOCKS = {"mlr": "ThermalCompMlr", "kalman": "ThermalCompKalman"}


def recording() -> Path:
    return Path(str(resources.files("thermoplc").joinpath("data", "fl_thermal", "fl_thermal.csv")))


def run_demo(out: Path, force: bool = False) -> int:
    for kind, block_name in BLOCKS.items():  # every output checked before anything is printed or written
        for path in (out / f"{kind}.json", out / f"{block_name}.scl", out / f"{block_name}.verify.txt"):
            check_output(path, force)
    data = recording()
    table = read_table(data)
    hours = table.columns["time_s"][-1] / 3600
    print(f"thermoplc demo on FL_THERMAL ({data}): {table.rows} rows, {hours:.1f} h, MIT licence (see LICENSE beside it)")
    print(f"  target {TARGET}; temperatures {', '.join(TEMPS)} (t5 hottest = heat source, t1 best correlated with "
          f"{TARGET} in the first 24 h); ambient {AMBIENT} (smallest spread, not heated by the spindle); speed {SPEED}")
    print(f"  fit on the first 24 h, predict the remaining {hours - 24:.1f} h, generate TIA blocks, verify every row")
    rows = []
    written = []
    for kind, block_name in BLOCKS.items():
        roles = kind_of(kind).roles
        request = FitRequest(kind, TARGET, TEMPS, SPEED if "speed" in roles else None,
                             AMBIENT if "ambient" in roles else None, train_until=TRAIN_UNTIL_S, block_name=block_name)
        model = fit([table], request)
        model_path = out / f"{kind}.json"
        block_path = out / f"{block_name}.scl"
        report_path = out / f"{block_name}.verify.txt"
        write_atomic(model_path, model.to_json())
        written.append(model_path)
        refused = refusal(model)
        if refused:  # the gate `generate` applies: no block for a model that does not compensate
            print(f"  {kind}: no block: {refused}")
            _remove_stale(block_path, report_path)
            continue
        write_atomic(block_path, generate(model, str(model_path), output=str(block_path)).text)
        report = verify_against_model(str(block_path), model, str(model_path), table)
        write_atomic(report_path, f"thermoplc {__version__} verify {block_path.name} --model {model_path.name}\n"
                     + report.text() + "\n")
        written += [block_path, report_path]
        m = model.metrics
        rows.append((kind, m["train"]["rmse_um"], m["held_out"]["rmse_um"], m["held_out"]["max_abs_um"],
                     m["held_out"]["zero_rmse_um"], m["start"]["max_abs_um"], m["float32_vs_float64_max_um"],
                     "bit-exact" if report.ok else "MISMATCH", report.cycles))
        if not report.ok:
            print(report.text())
    print(f"\n  {'model':<8}{'fit RMSE':>10}{'pred RMSE':>11}{'pred max':>10}{'none':>10}{'start':>8}{'f32-f64':>10}"
          f"  verify")
    for kind, fit_rmse, pred_rmse, pred_max, none, start, quant, verdict, cycles in rows:
        print(f"  {kind:<8}{fit_rmse:>8.2f}um{pred_rmse:>9.2f}um{pred_max:>8.1f}um{none:>8.2f}um{start:>6.2f}um"
              f"{quant:>8.1e}um  {verdict} over {cycles} cycles")
    print(f"\nfiles written to {out}/:")
    for path in written:
        print(f"  {path}")
    return 0 if len(rows) == len(BLOCKS) and all(r[7] == "bit-exact" for r in rows) else 1


def _remove_stale(*paths: Path) -> None:
    """An earlier run's block beside a model it no longer belongs to would be imported as that model's."""
    for path in paths:
        if path.exists():
            path.unlink()
            print(f"  removed {path}: written by an earlier run for a model this run refused")
