"""Replay speed of the ST interpreter per generated block, on twin data it makes itself.

    python benchmarks/replay.py [--hours H]

Prints cycles per second of the interpreter and of the numpy float32 reference for the same
block, measured in one run (ratios are what to compare; absolute numbers depend on the machine).
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from thermoplc.generator.lower import lower
from thermoplc.generator.printer import render
from thermoplc.models.fit import FitRequest, fit
from thermoplc.models.kalman import FitOptions
from thermoplc.models.reference import model_inputs, predict
from thermoplc.models.table import read_table, write_table
from thermoplc.models.twin import simulate
from thermoplc.verifier.interpreter import Machine
from thermoplc.verifier.parser import parse_text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=48.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "twin.csv"
        path.write_text(write_table(simulate(args.hours, seed=1)))
        table = read_table(path)
    print(f"{'block':<8}{'cycles':>9}{'interpreter c/s':>18}{'f32 reference c/s':>20}{'ratio':>8}")
    for kind in ("mlr", "kalman"):
        request = FitRequest(kind, "E_z_um", ("T_motor", "T_bearing"), "n_rpm", "T_env",
                             train_until=args.hours * 1800, options=FitOptions(population=12, generations=3))
        model = fit([table], request)
        machine = Machine(parse_text(render(lower(model))))
        inputs = model_inputs(model, table)
        columns = {name: col.tolist() for name, col in inputs.items()}
        start = time.perf_counter()
        machine.replay(columns, table.rows)
        interp = table.rows / (time.perf_counter() - start)
        start = time.perf_counter()
        predict(model, inputs, "f32")
        reference = table.rows / (time.perf_counter() - start)
        print(f"{kind:<8}{table.rows:>9}{interp:>18,.0f}{reference:>20,.0f}{interp / reference:>8.2f}")


if __name__ == "__main__":
    main()
