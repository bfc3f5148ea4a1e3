"""Replay speed per block and engine, on twin data the script makes itself, measured in one run.

    python benchmarks/replay.py [--cycles 3000000] [--interp-cycles 20000] [--json]

Engines: `interp` (the reference interpreter), `fast` (the block compiled to C with every check
verify relies on), `c_plain` (the same C without run-time checks: the plain loop over the same
arithmetic, the physical limit on this machine) and `reference` (the model's numpy float32
reference that verify compares with). Blocks are the golden models of every kind. Cycles per
second are best of three; ratios are to the interpreter in the same run. With --json the last
line is one JSON object {"<block>": {"<engine>": cycles_per_s, ...}, ...}.
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.golden_models import GOLDEN, KINDS, golden_block  # noqa: E402
from thermoplc.models.modelfile import load_model  # noqa: E402
from thermoplc.models.reference import block_outputs, model_inputs  # noqa: E402
from thermoplc.models.safety import Limits  # noqa: E402
from thermoplc.recordings.table import read_table, write_table  # noqa: E402
from thermoplc.machines.cascade import simulate  # noqa: E402
from thermoplc.verifier.engines.interpreter import Machine  # noqa: E402
from thermoplc.verifier.engines.native import NativeBlock  # noqa: E402
from thermoplc.verifier.reading.block_file import parse_file  # noqa: E402


def _best(run, repeat: int = 3) -> float:
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return best


def measure(kind: str, table, cycles: int, interp_cycles: int) -> dict:
    model = load_model(GOLDEN / f"{kind}.json")
    program = parse_file(golden_block(kind, "tia"))
    inputs = model_inputs(model, table)
    repeats = -(-cycles // table.rows)
    long = {name: np.tile(col, repeats)[:cycles] for name, col in inputs.items()}
    short = {name: col[:interp_cycles].tolist() for name, col in inputs.items()}
    rates = {}
    machine = Machine(program)

    def interp():
        machine.reset()
        machine.replay(short, interp_cycles)
    rates["interp"] = interp_cycles / _best(interp, 1)
    for engine, checked in (("fast", True), ("c_plain", False)):
        block = NativeBlock(program, checked)

        def run():
            block.reset()
            assert block.run(long, len(next(iter(long.values())))) is not None
        rates[engine] = cycles / _best(run)
    reference_rows = {name: col[:interp_cycles] for name, col in inputs.items()}
    block_outputs(model, {name: col[:10] for name, col in inputs.items()}, "f32", Limits())  # loads the compiled loops
    rates["reference"] = interp_cycles / _best(lambda: block_outputs(model, reference_rows, "f32", Limits()), 3)
    return rates


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=3_000_000, help="cycles per native run")
    parser.add_argument("--interp-cycles", type=int, default=20_000, help="cycles per interpreter run")
    parser.add_argument("--json", action="store_true", help="print the results as JSON on the last line")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "twin.csv"
        path.write_text(write_table(simulate(72, seed=1)))
        table = read_table(path)
    results = {}
    print(f"{'block':<10}{'interp c/s':>12}{'fast c/s':>14}{'c_plain c/s':>14}{'reference c/s':>15}"
          f"{'fast/interp':>13}{'fast/c_plain':>14}")
    for kind in KINDS:
        r = measure(kind, table, args.cycles, min(args.interp_cycles, table.rows))
        results[kind] = {k: round(v) for k, v in r.items()}
        print(f"{kind:<10}{r['interp']:>12,.0f}{r['fast']:>14,.0f}{r['c_plain']:>14,.0f}{r['reference']:>15,.0f}"
              f"{r['fast'] / r['interp']:>13,.0f}{r['fast'] / r['c_plain']:>14.2f}", flush=True)
    year = 365 * 24 * 3600
    print(f"a year of 1 Hz data ({year:,} cycles): kalman fast engine {year / results['kalman']['fast']:.1f} s, "
          f"mlr {year / results['mlr']['fast']:.1f} s")
    if args.json:
        print(json.dumps(results, sort_keys=True))


if __name__ == "__main__":
    main()
