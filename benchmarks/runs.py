"""What the detection benchmarks share: one BLAS thread per job (imported before numpy: small
matrices in several processes slow down 5x with threaded BLAS), the process pool, the JSON dump
and the printed table and summary."""
from __future__ import annotations

import json
import os
from concurrent.futures import ProcessPoolExecutor
from typing import Callable

for _threads in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_threads, "1")


def run_and_print(one: Callable[[tuple], dict], cases: list[tuple], jobs: int, json_path: str | None,
                  table: Callable[[list[dict]], list[str]], summary: Callable[[list[dict]], list[str]]) -> list[dict]:
    """Every case through `one` on `jobs` processes; the results to `json_path` when given, then
    the table and the summary printed. Returns the results in the order of `cases`."""
    with ProcessPoolExecutor(jobs) as pool:
        results = list(pool.map(one, cases))
    if json_path:
        with open(json_path, "w", encoding="utf-8") as out:
            json.dump(results, out, indent=1)
    print("\n".join(table(results)))
    print()
    print("\n".join(summary(results)))
    return results
