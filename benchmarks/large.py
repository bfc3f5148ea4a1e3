"""Verify a long recording end to end and report time and peak memory (CSV and .npz).

    python benchmarks/large.py [--rows 2600000] [--kind kalman]

Writes a recording of `rows` calls (the 72 h twin repeated, time continuing), generates the
golden block of `kind`, and runs `thermoplc verify` on the CSV and on the same data as .npz in
child processes; prints wall time and peak resident memory of each run.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from scripts.regen_golden import GOLDEN, golden_block  # noqa: E402
from thermoplc.machines.cascade import simulate  # noqa: E402


def write_recording(folder: Path, rows: int) -> tuple[Path, Path]:
    base = simulate(72, seed=1)
    names = list(base)
    repeats = -(-rows // len(base["time_s"]))
    columns = {name: np.tile(np.asarray(base[name], np.float64), repeats)[:rows] for name in names}
    columns["time_s"] = np.arange(rows) * 10.0
    csv_path, npz_path = folder / "long.csv", folder / "long.npz"
    with open(csv_path, "w") as f:
        f.write(",".join(names) + "\n")
        np.savetxt(f, np.column_stack([columns[n] for n in names]), delimiter=",", fmt="%.6f")
    np.savez(npz_path, **columns)
    return csv_path, npz_path


CHILD = ("import resource, sys\nfrom thermoplc.cli import main\n"
         "try:\n    code = main(sys.argv[1:])\nfinally:\n"
         "    print('peak-rss-kib', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)\n"
         "sys.exit(code)\n")


def run(args: list[str]) -> tuple[float, float, str]:
    """Wall time, the child's own peak RSS (MiB) and the first line it printed."""
    start = time.perf_counter()
    result = subprocess.run([sys.executable, "-c", CHILD, *args], capture_output=True, text=True)
    seconds = time.perf_counter() - start
    peak = next(int(line.split()[1]) for line in result.stderr.splitlines() if line.startswith("peak-rss-kib"))
    first = (result.stdout or result.stderr).splitlines()[0]
    return seconds, peak / 1024, first


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=2_600_000)
    parser.add_argument("--kind", default="kalman")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        start = time.perf_counter()
        csv_path, npz_path = write_recording(folder, args.rows)
        print(f"wrote {args.rows:,} rows ({csv_path.stat().st_size / 2**20:,.0f} MiB CSV, "
              f"{npz_path.stat().st_size / 2**20:,.0f} MiB npz) in {time.perf_counter() - start:.1f} s")
        block, model = golden_block(args.kind, "tia"), GOLDEN / f"{args.kind}.json"
        print(f"{'input':<8}{'seconds':>9}{'peak RSS MiB':>14}  result")
        for label, data in (("csv", csv_path), ("npz", npz_path)):
            seconds, peak, first = run(["verify", str(block), "--model", str(model), "--data", str(data)])
            print(f"{label:<8}{seconds:>9.1f}{peak:>14,.0f}  {first[:70]}")


if __name__ == "__main__":
    main()
