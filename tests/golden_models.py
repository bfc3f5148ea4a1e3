"""The golden models the tests (and benchmarks) read: tests/golden/<kind>.json, their blocks in every
dialect, and the twin data they were fitted on. `python scripts/regen_golden.py` rewrites the blocks
(and with --refit the model files) from these same definitions.
"""
from __future__ import annotations

from pathlib import Path

from thermoplc.base.version import __version__
from thermoplc.generator.lower import lower
from thermoplc.generator.printer import DIALECTS as PRINTER_DIALECTS, render, render_plcopen
from thermoplc.machines.cascade import simulate
from thermoplc.models.kinds import names as kind_names
from thermoplc.models.modelfile import load_model
from thermoplc.recordings.table import read_table, write_table

GOLDEN = Path(__file__).resolve().parent / "golden"
TWIN = {"hours": 12, "seed": 7}
BATCH_AMBIENTS_C = (14.0, 19.0, 26.0, 31.0)  # piecewise library batches, one per node region
# every kind of the registry, and the lumped model as `fit` identifies it (the `lumped` golden is diagnose's)
KINDS = (*kind_names(), "lumped_identified")
DIALECTS = tuple(PRINTER_DIALECTS)
# fused blocks (fit --probe): a golden model with a probe fusion that keeps every state (rate, decay), its blocks
# reviewed like the others; verified with a probing every FUSED_EVERY calls of the golden twin
FUSED = {"kalman_fused": "kalman"}
FUSED_EVERY = 90


def golden_twin_csv(folder: Path) -> Path:
    path = folder / "golden_twin.csv"
    path.write_text(write_table(simulate(TWIN["hours"], seed=TWIN["seed"])))
    return path


def batch_csvs(folder: Path) -> list[Path]:
    """Short runs started at different ambient temperatures (the piecewise model's batches)."""
    paths = []
    for k, ambient in enumerate(BATCH_AMBIENTS_C):
        path = folder / f"batch_{ambient:g}C.csv"
        path.write_text(write_table(simulate(8, seed=20 + k, ambient_start=ambient)))
        paths.append(path)
    return paths


def golden_block(kind: str, dialect: str) -> Path:
    """tests/golden/<kind>.<dialect><suffix>; dialect 'plcopen' is the iec block as PLCopen XML."""
    suffix = ".xml" if dialect == "plcopen" else PRINTER_DIALECTS[dialect].suffix
    return GOLDEN / f"{kind}.{dialect}{suffix}"


def rendered(kind: str, dialect: str) -> str:
    block = lower(load_model(GOLDEN / f"{kind}.json"))
    return render_plcopen(block, __version__) if dialect == "plcopen" else render(block, dialect)


# the golden test bench (issue 64): a short window of the fused golden block on the golden twin, in every dialect
BENCH = {"kind": "kalman_fused", "first": 30, "calls": 12, "rows_per_cycle": 5}


def golden_bench(dialect: str) -> Path:
    """tests/golden/bench.<dialect><suffix>: the test bench of golden_block(BENCH kind, dialect)."""
    suffix = ".xml" if dialect == "plcopen" else PRINTER_DIALECTS[dialect].suffix
    return GOLDEN / f"bench.{dialect}{suffix}"


def rendered_bench(dialect: str, folder: Path) -> str:
    from thermoplc import pipeline
    kind = BENCH["kind"]
    table = read_table(golden_twin_csv(folder))
    return pipeline.testbench(str(golden_block(kind, dialect)), load_model(GOLDEN / f"{kind}.json"),
                              str(GOLDEN / f"{kind}.json"), table, BENCH["first"], BENCH["calls"],
                              BENCH["rows_per_cycle"], probe_every=FUSED_EVERY).text
