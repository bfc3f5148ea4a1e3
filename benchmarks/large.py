"""Verify a long recording end to end and report time, the share of each stage and peak memory.

    python benchmarks/large.py [--rows 2600000] [--kind kalman] [--sources npz,csv,parquet]
    python benchmarks/large.py --rows 31536000            # a year of calls
    python benchmarks/large.py --fleet 100                # 100 machine-months through --manifest

Writes a recording of `rows` calls (the 72 h twin repeated, time continuing; every column,
written chunk by chunk so the writer's memory stays small), generates the golden block of
`kind`, and runs `thermoplc verify` on each source in a child process; prints wall time, the
seconds of each stage (read, reference, replay, compare; 'other' is interpreter start, imports,
parsing and compiling the block) and the child's peak resident memory.

--fleet N lists one machine-month (30 days at 1 Hz: 2,592,000 calls, .npz) N times in a
manifest and runs `verify --manifest` in a child: the throughput of fleet verification.
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

import argparse
import json
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.golden_models import GOLDEN, golden_block  # noqa: E402
from thermoplc.machines.cascade import simulate  # noqa: E402

MONTH_ROWS = 30 * 24 * 3600


def _pieces(rows: int):
    """(names, columns of the next piece) of the repeated twin, time continuing, 6 decimals."""
    base = simulate(72, seed=1)
    names = list(base)
    block = {name: np.round(np.asarray(base[name], np.float64), 6) for name in names}
    period = len(block["time_s"])
    for start in range(0, rows, period):
        n = min(period, rows - start)
        piece = {name: block[name][:n] for name in names}
        piece["time_s"] = np.arange(start, start + n) * 10.0
        yield names, piece


def write_recording(folder: Path, rows: int, sources=("csv", "npz")) -> dict:
    """The recording in each format asked for; returns source -> path."""
    paths = {}
    if "csv" in sources:
        import pyarrow as pa
        import pyarrow.csv as pacsv
        paths["csv"] = folder / "long.csv"
        with open(paths["csv"], "wb") as f:
            for names, piece in _pieces(rows):
                if not f.tell():
                    f.write((",".join(names) + "\n").encode())
                pacsv.write_csv(pa.table(piece), f, pacsv.WriteOptions(include_header=False, quoting_style="none"))
    if "parquet" in sources:
        import pyarrow as pa
        import pyarrow.parquet as pq
        paths["parquet"] = folder / "long.parquet"
        writer = None
        for names, piece in _pieces(rows):
            table = pa.table(piece)
            writer = writer or pq.ParquetWriter(paths["parquet"], table.schema)
            writer.write_table(table)
        writer.close()
    if "npz" in sources:  # np.savez's layout (stored .npy members), one column at a time
        paths["npz"] = folder / "long.npz"
        names = next(_pieces(1))[0]
        with zipfile.ZipFile(paths["npz"], "w", zipfile.ZIP_STORED, allowZip64=True) as archive:
            for name in names:
                with archive.open(f"{name}.npy", "w", force_zip64=True) as member:
                    np.lib.format.write_array_header_2_0(
                        member, {"descr": "<f8", "fortran_order": False, "shape": (rows,)})
                    for _, piece in _pieces(rows):
                        member.write(np.ascontiguousarray(piece[name], "<f8").tobytes())
    return paths


# the child notes the route and stage times of verify's streamed reading by wrapping the function the command calls
CHILD = ("import json, resource, sys, time\nstart = time.perf_counter()\nfrom thermoplc.cli import main\n"
         "stages = {}\ntry:\n    from thermoplc.verifier.replays import stream\n    plain = stream.verify_streaming\n"
         "    def noting(*args, **kwargs):\n        streamed = plain(*args, **kwargs)\n"
         "        stages.update(route=streamed.route, **streamed.seconds)\n        return streamed\n"
         "    stream.verify_streaming = noting\n"
         "except ImportError:\n    pass  # a thermoplc before the verifier's split: no stages\n"
         "try:\n    code = main(sys.argv[1:])\nfinally:\n"
         "    print('stages', json.dumps(stages), file=sys.stderr)\n"
         "    print('peak-rss-kib', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)\n"
         "sys.exit(code)\n")


PYTHON = [sys.executable]


def run(args: list[str]) -> tuple[float, float, str, dict, str]:
    """Wall time, the child's own peak RSS (MiB), the first line it printed, its stage times, stdout."""
    start = time.perf_counter()
    result = subprocess.run([*PYTHON, "-c", CHILD, *args], capture_output=True, text=True)
    seconds = time.perf_counter() - start
    lines = result.stderr.splitlines()
    peak = next(int(line.split()[1]) for line in lines if line.startswith("peak-rss-kib"))
    stages = next((json.loads(line.split(" ", 1)[1]) for line in lines if line.startswith("stages ")), {})
    first = (result.stdout or result.stderr).splitlines()[0]
    return seconds, peak / 1024, first, stages, result.stdout


STAGES = ("read", "reference", "replay", "compare")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=2_600_000)
    parser.add_argument("--kind", default="kalman")
    parser.add_argument("--sources", default="npz,csv", help="comma-separated: npz, csv, parquet")
    parser.add_argument("--fleet", type=int, default=0, help="machine-months to verify through --manifest")
    parser.add_argument("--folder", help="write the recordings here (default: a temporary folder)")
    parser.add_argument("--data", nargs="+", help="verify these recordings (of --rows rows) instead of writing one")
    parser.add_argument("--python", help="run the verify child with this interpreter (another install, for before/after)")
    args = parser.parse_args()
    if args.python:
        PYTHON[:] = [args.python]
    with tempfile.TemporaryDirectory(dir=args.folder) as tmp:
        folder = Path(tmp)
        block, model = golden_block(args.kind, "tia"), GOLDEN / f"{args.kind}.json"
        if args.fleet:
            fleet(folder, block, model, args.fleet)
            return
        if args.data:
            paths = {Path(p).suffix.lstrip("."): Path(p) for p in args.data}
            sources = tuple(paths)
        else:
            sources = tuple(args.sources.split(","))
            start = time.perf_counter()
            paths = write_recording(folder, args.rows, sources)
            sizes = ", ".join(f"{p.stat().st_size / 2**20:,.0f} MiB {s}" for s, p in paths.items())
            print(f"wrote {args.rows:,} rows ({sizes}) in {time.perf_counter() - start:.1f} s")
        print(f"{'input':<8}{'rows':>12}{'seconds':>9}" + "".join(f"{s:>16}" for s in (*STAGES, "other"))
              + f"{'peak MiB':>10}{'calls/s':>13}  result")
        for source in sources:
            seconds, peak, first, stages, _ = run(["verify", str(block), "--model", str(model), "--data",
                                                   str(paths[source])])
            cells = []
            for stage in STAGES:
                value = stages.get(stage)
                cells.append(f"{value:7.2f} ({value / seconds:3.0%})" if value is not None else "-")
            other = seconds - sum(stages.get(s, 0.0) for s in STAGES)
            cells.append(f"{other:7.2f} ({other / seconds:3.0%})")
            print(f"{source:<8}{args.rows:>12,}{seconds:>9.1f}" + "".join(f"{c:>16}" for c in cells)
                  + f"{peak:>10,.0f}{args.rows / seconds:>13,.0f}  {first[:60]}")
            if stages.get("route", "streamed") != "streamed":
                print(f"        route: {stages['route']}")


def fleet(folder: Path, block: Path, model: Path, months: int) -> None:
    start = time.perf_counter()
    path = write_recording(folder, MONTH_ROWS, ("npz",))["npz"]
    print(f"wrote one machine-month, {MONTH_ROWS:,} rows ({path.stat().st_size / 2**20:,.0f} MiB npz) "
          f"in {time.perf_counter() - start:.1f} s; the manifest lists it {months} times")
    manifest = folder / "fleet.csv"
    manifest.write_text("block,data,model\n" + "".join(f"{block},{path},{model}\n" for _ in range(months)))
    seconds, peak, _, _, stdout = run(["verify", "--manifest", str(manifest)])
    rows = months * MONTH_ROWS
    print(stdout.splitlines()[-2] if len(stdout.splitlines()) > 1 else stdout)
    print(stdout.splitlines()[-1])
    print(f"fleet: {months} machine-months, {rows:,} calls in {seconds:.1f} s: {rows / seconds:,.0f} calls/s, "
          f"{seconds / months:.2f} s per machine-month, peak {peak:,.0f} MiB")


if __name__ == "__main__":
    main()
