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
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.kinds_on_data import PROBE_EVERY, fitted_kinds  # noqa: E402
from thermoplc.pipeline import generate  # noqa: E402
from thermoplc.verifier.replays.faults import verify_faults  # noqa: E402

KINDS = ("mlr", "kalman", "lumped", "dlag", "gm0n", "gm1n", "bayes", "bpnn")
QUICK = ("mlr", "kalman")


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
    print("um; move: largest |output - fault-free output|; error: faulted block's largest |output - drift| over the "
          "case's calls; none: largest |drift| there")
    print(f"{'data':<12}{'kind':<11}{'input':<14}{'fault':<15}{'move':>10}{'flagged':>9}{'error':>9}{'none':>8}  verdict")
    failed = []
    for label, kind, table, model in fitted_kinds(folder, kinds):
        if isinstance(model, str):
            print(f"{label:<12}{kind:<11}refused: {model}")
            continue
        every = PROBE_EVERY if model.probe is not None else None
        failed.append((label, kind, judged(label, kind, model, table, folder, every)))
    print("failing cases: " + "; ".join(f"{label} {kind} {count}" for label, kind, count in failed))


if __name__ == "__main__":
    main()
