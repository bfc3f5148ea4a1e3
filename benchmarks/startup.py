"""How long the commands take on a short job, where start-up is most of it (issue 40).

    python benchmarks/startup.py [--repeat 5] [--install PATH ...]

Runs `thermoplc --version`, `--help`, and `verify`, `generate`, `diff` on the 24 h twin at 10 s (8,641
calls, the Kalman fusion block of the README) in fresh processes, `--repeat` times each, and prints the
median wall time per command. `verify` is timed twice: with the compiled block in the private cache (the
second run of a block, the usual case) and with the cache off (`THERMOPLC_NATIVE_CACHE=off`: every run
compiles). `--install PATH` times another installation as well (a folder `pip install --target PATH`
wrote, put first on PYTHONPATH), for a before/after table in one run; its bytecode is compiled first, as
pip compiles an installed package's (this one's source folder is compiled too).
"""
from __future__ import annotations

import argparse
import compileall
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TARGETS = {"--version": None, "--help": 0.2, "verify": 0.6, "verify, compiling": None, "generate": 0.5, "diff": 0.3}


def timed(command: list[str], folder: Path, env: dict) -> float:
    started = time.perf_counter()
    result = subprocess.run([sys.executable, "-m", "thermoplc", *command], cwd=folder, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)
    seconds = time.perf_counter() - started
    if result.returncode != 0:
        raise SystemExit(f"thermoplc {' '.join(command)} failed: {result.stderr.strip()}")
    return seconds


def prepare(folder: Path, env: dict) -> None:
    """The README's twin (24 h), its Kalman fit on the first 12 h and the block."""
    for command in (["twin", "--hours", "24", "--seed", "3", "-o", "twin.csv"],
                    ["fit", "--data", "twin.csv", "--model", "kalman", "--target", "E_z_um", "--temps",
                     "T_motor,T_bearing", "--speed", "n_rpm", "--ambient", "T_env", "--train-until", "43200",
                     "-o", "model.json"],
                    ["generate", "model.json", "--dialect", "tia", "-o", "ThermalComp.scl"]):
        subprocess.run([sys.executable, "-m", "thermoplc", *command], cwd=folder, env=env, check=True,
                       stdout=subprocess.DEVNULL, stdin=subprocess.DEVNULL)


def medians(folder: Path, env: dict, repeat: int) -> dict[str, float]:
    verify = ["verify", "ThermalComp.scl", "--model", "model.json", "--data", "twin.csv"]
    commands = {"--version": (["--version"], env), "--help": (["--help"], env), "verify": (verify, env),
                "verify, compiling": (verify, {**env, "THERMOPLC_NATIVE_CACHE": "off"}),
                "generate": (["generate", "model.json", "--dialect", "tia", "-o", "again.scl", "--force"], env),
                "diff": (["diff", "ThermalComp.scl", "again.scl"], env)}
    for command, command_env in commands.values():  # warm: bytecode, numba's cache, the compiled block
        timed(command, folder, command_env)
    return {name: statistics.median(timed(command, folder, command_env) for _ in range(repeat))
            for name, (command, command_env) in commands.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--install", nargs="*", default=[], help="other installations (pip install --target) to time")
    args = parser.parse_args()
    base = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "PYTHONPATH")}
    installs = {"this source": None, **{path: Path(path).resolve() for path in args.install}}
    columns = {}
    for label, path in installs.items():
        compileall.compile_dir(path or ROOT, quiet=1)
        env = {**base, **({"PYTHONPATH": str(path)} if path else {})}
        with tempfile.TemporaryDirectory() as tmp:
            prepare(Path(tmp), env)
            columns[label] = medians(Path(tmp), env, args.repeat)
    print(f"median of {args.repeat} runs, seconds (this machine: {os.cpu_count()} cores, shared)\n")
    print("| command | " + " | ".join(columns) + " | target |")
    print("| --- |" + " ---: |" * (len(columns) + 1))
    version = columns["this source"]["--version"]
    for name, target in TARGETS.items():
        cells = " | ".join(f"{values[name]:.2f}" for values in columns.values())
        print(f"| {name} | {cells} | {f'<= {target:g}' if target else '-'} |")
    print(f"\nverify / --version (this source): {columns['this source']['verify'] / version:.1f}")


if __name__ == "__main__":
    main()
