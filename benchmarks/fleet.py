"""A fleet through `verify --manifest`, and a campaign's fit and diagnosis: one process, `--jobs`, and a Dask
cluster of local workers.

    python benchmarks/fleet.py [--months 100] [--short 1000] [--workers 2] [--kind kalman] [--only campaign]

Writes one machine-month (30 days at 1 Hz: 2,592,000 calls, .npz) and lists it `--months` times in a
manifest, and the golden twin (a short CSV) `--short` times in another; verifies each manifest in a child
process with `--jobs 1`, `--jobs N` and on a Dask cluster started here as a user starts one (`dask scheduler`
and `dask worker --nworkers N --nthreads 1`, separate processes), then once more on the cluster with one
worker killed (SIGKILL) halfway through the machine-months. Prints seconds, calls per second and the ratio
to `--jobs N`; checks that every run's `--json` document is byte-identical to the one-process run's (every
pair reported once, the same verdicts, the killed run included); and from the measured seconds per
machine-month, how many workers verify 1,000 machines x 1 year in one night.

The campaign part: a twin campaign of `--fit-runs` runs of 8 h at 60 s fitted by `fit --model kalman --folds N`
(leave one run out, 20 GA generations) in one process and with `--scheduler` (the folds on the workers, the fit
on every row here), once more with a worker killed halfway; and `diagnose` of a 5-run campaign with a gear
switch hidden, in one process and with `--scheduler` (each round's candidates on the workers). Every model file
and findings file must be byte-identical to the one-process run's.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.large import MONTH_ROWS, write_recording  # noqa: E402
from tests.golden_models import GOLDEN, golden_block, golden_twin_csv  # noqa: E402

NIGHT_S = 8 * 3600
MACHINES, MONTHS_PER_YEAR = 1000, 12


class Cluster:
    """`dask scheduler` and `dask worker` as separate processes, as docs/performance.md starts them."""

    def __init__(self, folder: Path, workers: int):
        self.file = folder / "scheduler.json"
        self.processes = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--port", "0",
                                            "--dashboard-address", ":0", "--scheduler-file", str(self.file)],
                                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
        while not self.file.exists():
            time.sleep(0.1)
        time.sleep(0.2)
        self.address = json.loads(self.file.read_text())["address"]
        self.processes.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", self.address, "--nworkers", str(workers),
             "--nthreads", "1", "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client
        self.client = Client(self.address, set_as_default=False)
        self.client.wait_for_workers(workers, timeout=60)

    def kill_a_worker(self) -> int:
        """SIGKILL one worker process (its nanny starts another); its pid."""
        address = sorted(self.client.scheduler_info()["workers"])[0]
        pid = self.client.run(os.getpid, workers=[address])[address]
        os.kill(pid, signal.SIGKILL)
        return pid

    def close(self) -> None:
        self.client.close()
        for process in reversed(self.processes):
            process.terminate()
            process.wait(timeout=30)


def verify(manifest: Path, out: Path, options: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "thermoplc", "verify", "--manifest", str(manifest), *options,
                    "--json", str(out), "--force"], stdout=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
    return time.perf_counter() - started


def thermoplc(folder: Path, *argv: str) -> float:
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "thermoplc", *argv], cwd=folder, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, check=True)
    return time.perf_counter() - started


def campaign(folder: Path, cluster: Cluster, runs: int) -> None:
    """A campaign's fit and diagnosis in one process and on the cluster: seconds and whether the bytes agree."""
    thermoplc(folder, "twin", "--runs", str(runs), "--hours", "8", "--dt", "60", "--seed", "7", "--probe-minutes", "0",
              "-o", "fit_runs")
    thermoplc(folder, "twin", "--runs", "5", "--hours", "8", "--dt", "60", "--seed", "3", "--probe-minutes", "0",
              "--effect", "gear_ratio_switch:threshold_rpm=750", "-o", "gear_runs")
    fit = ("fit", "--data", "fit_runs", "--model", "kalman", "--target", "E_z_um", "--temps",
           "T_motor,T_bearing,T_struct", "--speed", "n_rpm", "--ambient", "T_env", "--folds", str(runs),
           "--generations", "20", "--force")
    diagnose = ("diagnose", "--data", "gear_runs", "--temps", "T_motor,T_bearing", "--speed", "n_rpm", "--ambient",
                "T_env", "--target", "E_z_um", "--force")
    on_cluster = ("--scheduler", cluster.address)
    rows = []
    for what, argv, outputs in ((f"fit, {runs} runs, leave one run out", fit, ("-o",)),
                                ("diagnose, 5 runs", diagnose, ("-o", "--json"))):
        runs_of = [("1 process", ()), (f"Dask, {len(cluster.client.scheduler_info()['workers'])} workers", on_cluster)]
        if what.startswith("fit"):
            runs_of.append(("Dask, one worker killed halfway", on_cluster))
        seconds, files = {}, {}
        for label, extra in runs_of:
            names = [f"{what[:3]}{len(seconds)}{option.replace('-', '_')}.json" for option in outputs]
            named = [item for option, name in zip(outputs, names) for item in (option, name)]
            killer = None
            if "killed" in label:
                killer = threading.Timer(seconds["1 process"] / 4, cluster.kill_a_worker)
                killer.start()
            seconds[label] = thermoplc(folder, *argv, *named, *extra)
            if killer:
                killer.join()
            files[label] = [(folder / n).read_bytes() for n in names]
            for k, n in enumerate(names):  # the findings name the model file: every output's name as OUT<k>
                files[label] = [content.replace(n.encode(), f"OUT{k}".encode()) for content in files[label]]
            rows.append((what, label, seconds[label], seconds[label] / seconds["1 process"],
                         files[label] == files["1 process"]))
    print("\n| job | run | seconds | / 1 process | same bytes as 1 process |")
    print("| --- | --- | ---: | ---: | --- |")
    for what, label, seconds, ratio, same in rows:
        print(f"| {what} | {label} | {seconds:.1f} | {ratio:.2f} | {same} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--months", type=int, default=100, help="machine-months in the long manifest")
    parser.add_argument("--short", type=int, default=1000, help="short pairs in the other manifest")
    parser.add_argument("--workers", type=int, default=2, help="--jobs and Dask workers")
    parser.add_argument("--kind", default="kalman")
    parser.add_argument("--fit-runs", type=int, default=20, help="runs of the campaign fitted with its folds")
    parser.add_argument("--only", choices=("verify", "campaign"), help="one part only (default: both)")
    args = parser.parse_args()
    block, model = golden_block(args.kind, "tia"), GOLDEN / f"{args.kind}.json"
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        month = write_recording(folder, MONTH_ROWS, ("npz",))["npz"]
        short = golden_twin_csv(folder)
        short_rows = sum(1 for _ in open(short)) - 1
        manifests = {"machine-months": (folder / "months.csv", args.months, MONTH_ROWS, month),
                     "short pairs": (folder / "short.csv", args.short, short_rows, short)}
        for path, count, _, data in manifests.values():
            path.write_text("block,data,model\n" + f"{block},{data},{model}\n" * count)
        cluster = Cluster(folder, args.workers)
        rows, documents, per_month = [], {}, None
        try:
            if args.only != "verify":
                campaign(folder, cluster, args.fit_runs)
            for name, (path, count, calls, _) in (manifests.items() if args.only != "campaign" else ()):
                runs = [("1 process", ["--jobs", "1"]), (f"--jobs {args.workers}", ["--jobs", str(args.workers)]),
                        (f"Dask, {args.workers} workers", ["--scheduler", cluster.address])]
                if name == "machine-months":
                    runs.append((f"Dask, {args.workers} workers, one killed halfway", ["--scheduler", cluster.address]))
                seconds = {}
                for label, options in runs:
                    out = folder / f"{name}-{len(seconds)}.json"
                    killer = None
                    if "killed" in label:
                        half = seconds[f"Dask, {args.workers} workers"] / 2
                        killer = threading.Timer(half, cluster.kill_a_worker)
                        killer.start()
                    seconds[label] = verify(path, out, options)
                    if killer:
                        killer.join()
                    documents[(name, label)] = out.read_bytes()
                    total = count * calls
                    rows.append((name, label, count, seconds[label], total / seconds[label]))
                if name == "machine-months":
                    per_month = seconds["1 process"] / count
                same = all(documents[(name, label)] == documents[(name, "1 process")] for label, _ in runs)
                verdicts = json.loads(documents[(name, "1 process")])["counts"]
                print(f"{name}: every run's --json identical to the one-process run: {same} ({verdicts})")
        finally:
            cluster.close()
    if args.only == "campaign":
        return
    jobs = {name: next(r[3] for r in rows if r[0] == name and r[1] == f"--jobs {args.workers}") for name in manifests}
    print(f"\n| manifest | run | pairs | seconds | calls/s | seconds / --jobs {args.workers} |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for name, label, count, seconds, rate in rows:
        print(f"| {name} | {label} | {count} | {seconds:.1f} | {rate:,.0f} | {seconds / jobs[name]:.2f} |")
    need = MACHINES * MONTHS_PER_YEAR * per_month
    workers = int(-(-need // NIGHT_S))
    print(f"\n1,000 machines x 1 year = {MACHINES * MONTHS_PER_YEAR:,} machine-months at {per_month:.2f} s each on one "
          f"worker (the file in the page cache): {need / 3600:,.1f} worker-hours, {workers} worker"
          f"{'s' if workers != 1 else ''} for one {NIGHT_S // 3600} h night")


if __name__ == "__main__":
    main()
