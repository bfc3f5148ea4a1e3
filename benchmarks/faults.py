"""What one fault does to each kind's block, judged against no compensation (issue 61, `verify --faults`).

    python benchmarks/faults.py [--quick]

On FL_THERMAL ch3 (the demo's sensors and split) and on the cascade twin (seed 3, 48 h, fit on the first 24 h),
each kind is fitted, generated (TIA) and replayed by `verify --faults`: every sensor fault on every temperature,
the Enable/Reset actions and, for the fused mlr block of each (`fit --probe --probe-every 120`), the probing
faults. Per case: the largest move of the output from the fault-free block's, whether a status bit came up, the
faulted block's largest distance from the measured drift over the case's calls beside no compensation's, and
the verdict (FAIL: further than no compensation and unflagged). Last, per data and kind, how many cases fail.
`--quick`: mlr and kalman only. Seeded: the same run prints the same table.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

from thermoplc.demo import AMBIENT, SPEED, TARGET, TEMPS, recording
from thermoplc.base.errors import UserError
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.models.kinds import kind_of
from thermoplc.models.modelfile import load_model
from thermoplc.pipeline import generate
from thermoplc.recordings.table import read_table
from thermoplc.verifier.faults import verify_faults

KINDS = ("mlr", "kalman", "lumped", "dlag", "gm0n", "gm1n", "bayes", "bpnn")
QUICK = ("mlr", "kalman")
TRAIN_S = 24 * 3600.0
PROBE_EVERY = 120


def twin(folder: Path) -> Path:
    path = folder / "twin.csv"
    subprocess.run([sys.executable, "-m", "thermoplc", "twin", "--hours", "48", "--seed", "3", "-o", str(path)],
                   check=True, capture_output=True)
    return path


def fused(folder: Path, data: Path, target: str, temps: tuple[str, ...]) -> Path:
    path = folder / f"fused_{data.stem}.json"
    subprocess.run([sys.executable, "-m", "thermoplc", "fit", "--data", str(data), "--model", "mlr", "--target",
                    target, "--temps", ",".join(temps), "--train-until", str(TRAIN_S), "--probe", "--probe-every",
                    str(PROBE_EVERY), "-o", str(path)], check=True, capture_output=True)
    return path


def judged(label: str, kind: str, model, table, folder: Path, probe_every: int | None = None) -> int:
    block = folder / f"{label}_{kind}.scl"
    block.write_text(generate(model, "model", accept_unvalidated=True).text)
    report = verify_faults(str(block), model, table, probe_every=probe_every)
    for c in report.cases:
        error, none = (f"{c.harm.worst:>9.2f}", f"{c.harm.none:>8.2f}") if c.harm else (f"{'-':>9}", f"{'-':>8}")
        print(f"{label:<12}{kind:<11}{c.sensor:<14}{c.kind.name:<15}{c.max_change:>10.2f}{'yes' if c.flagged else 'no':>9}"
              f"{error}{none}  {'ok' if c.ok else 'FAIL'}", flush=True)
    return sum(not c.ok for c in report.cases)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    kinds = QUICK if parser.parse_args().quick else KINDS
    folder = Path(tempfile.mkdtemp(prefix="thermoplc-faults-"))
    data = {"FL_THERMAL": (recording(), TARGET, TEMPS, SPEED, AMBIENT),
            "twin": (twin(folder), "E_z_um", ("T_motor", "T_bearing"), "n_rpm", "T_env")}
    print("um; move: largest |output - fault-free output|; error: faulted block's largest |output - drift| over the "
          "case's calls; none: largest |drift| there")
    print(f"{'data':<12}{'kind':<11}{'input':<14}{'fault':<15}{'move':>10}{'flagged':>9}{'error':>9}{'none':>8}  verdict")
    failed = []
    for label, (path, target, temps, speed, ambient) in data.items():
        table = read_table(path)
        for kind in kinds:
            roles = kind_of(kind).roles
            request = FitRequest(kind, target, temps, speed if "speed" in roles else None,
                                 ambient if "ambient" in roles else None, train_until=TRAIN_S, settings={"seed": 0})
            try:
                model = fit([table], request)
            except UserError as exc:
                print(f"{label:<12}{kind:<11}refused: {str(exc).split(': ', 1)[-1][:90]}")
                continue
            failed.append((label, kind, judged(label, kind, model, table, folder)))
        model = load_model(fused(folder, Path(path), target, temps))
        failed.append((label, "mlr fused", judged(label, "mlr fused", model, table, folder, PROBE_EVERY)))
    print("failing cases: " + "; ".join(f"{label} {kind} {count}" for label, kind, count in failed))


if __name__ == "__main__":
    main()
