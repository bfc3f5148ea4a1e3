"""GA-BP with paper 002's or paper 000's genetic operators: which predicts better held out?

    python benchmarks/ga_operators.py [--seeds 3]

`fit --model bpnn --ga-operators paper002|paper000` on FL_THERMAL ch3 and ch5 (four fcm-grey
sensors chosen on the first 24 h, fitted there, the remaining 22 h predicted) and on twins of seeds
20.. (24 h, first half fitted), each with GA seeds 0..N-1. Prints the held-out RMSE per case and
operator set, the median over seeds and how many cases each set wins. The default of
`--ga-operators` follows this table, real data first.
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402

from benchmarks.fl_thermal import chosen_sensors  # noqa: E402
from thermoplc.demo import TRAIN_UNTIL_S, recording  # noqa: E402
from thermoplc.machines.cascade import simulate  # noqa: E402
from thermoplc.fitting.fit import FitRequest, fit  # noqa: E402
from thermoplc.models.reference import model_inputs, predict  # noqa: E402
from thermoplc.recordings.table import read_table, write_table  # noqa: E402

OPERATORS = ("paper002", "paper000")
TWIN_SEEDS = (20, 21, 22)


def held_out_rmse(table, channel: str, sensors: tuple[str, ...], split: int, operators: str, seed: int) -> float:
    model = fit([table], FitRequest("bpnn", channel, sensors, train_rows=split,
                                    settings={"seed": seed, "ga_operators": operators}))
    residual = predict(model, model_inputs(model, table), "f64")[model.target.name][split:] - table.columns[channel][split:]
    return float(np.sqrt(np.mean(residual ** 2)))


def cases(folder: Path):
    table = read_table(recording())
    split = int(np.searchsorted(table.columns["time_s"], table.columns["time_s"][0] + TRAIN_UNTIL_S, side="right"))
    for channel in ("ch3_um", "ch5_um"):
        yield f"FL_THERMAL {channel}", table, channel, chosen_sensors(table, channel, split), split
    for seed in TWIN_SEEDS:
        path = folder / f"twin{seed}.csv"
        path.write_text(write_table(simulate(24, seed=seed)))
        twin = read_table(path)
        yield f"twin seed {seed}", twin, "E_z_um", ("T_motor", "T_bearing"), twin.rows // 2


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3, help="GA seeds per case (default: %(default)s)")
    args = parser.parse_args()
    print(f"{'case':<20}{'none um':>9}" + "".join(f"{f'{o} median um':>20}" for o in OPERATORS) + "   per seed")
    wins = dict.fromkeys(OPERATORS, 0)
    with tempfile.TemporaryDirectory() as folder:
        for label, table, channel, sensors, split in cases(Path(folder)):
            none = float(np.sqrt(np.mean(table.columns[channel][split:] ** 2)))
            found = {o: [held_out_rmse(table, channel, sensors, split, o, s) for s in range(args.seeds)]
                     for o in OPERATORS}
            medians = {o: statistics.median(v) for o, v in found.items()}
            wins[min(medians, key=medians.get)] += 1
            each = "; ".join(f"{o}: " + " ".join(f"{x:.2f}" for x in v) for o, v in found.items())
            print(f"{label:<20}{none:>9.2f}" + "".join(f"{medians[o]:>20.2f}" for o in OPERATORS) + f"   {each}",
                  flush=True)
    print("lower median held-out RMSE in " + ", ".join(f"{o}: {n} cases" for o, n in wins.items()))


if __name__ == "__main__":
    main()
