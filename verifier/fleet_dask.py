"""verify --manifest on a Dask distributed cluster (`--scheduler tcp://HOST:PORT`): the pairs of a fleet as tasks.

Each task is one whole (block, data, model) pair, `fleet.verify_pair`, the function the processes of `--jobs`
run, so a pair's outcome does not depend on where it ran (base/cluster.py: paths travel, never data; a
worker that dies costs a retry). Outcomes are put in manifest order; a pair whose workers kept dying is an
"error" outcome of its own, the others are verified.
"""
from __future__ import annotations

import time
from functools import partial

from thermoplc.base.cluster import Lost, connect
from thermoplc.verifier.fleet import Outcome, Pair, verify_pair


def verify_on_cluster(pairs: list[Pair], engine: str, scheduler: str) -> tuple[list[Outcome], float]:
    """Outcomes in manifest order from the cluster at `scheduler`, and the wall time of the whole fleet."""
    started = time.perf_counter()
    cluster = connect(scheduler)
    try:
        outcomes: list[Outcome | None] = [None] * len(pairs)
        for k, result in cluster.run(partial(verify_pair, engine=engine), pairs, "pair",
                                 [f"the pair of manifest line {p.line}" for p in pairs]):
            outcomes[k] = (Outcome(pairs[k], "error", str(result), str(result)) if isinstance(result, Lost)
                           else result)
        return [o for o in outcomes if o is not None], time.perf_counter() - started
    finally:
        cluster.close()
