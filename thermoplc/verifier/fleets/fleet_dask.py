"""verify --manifest or a campaign on a Dask distributed cluster (`--scheduler tcp://HOST:PORT`): the pairs as tasks.

Each task is one whole (block, data, model) pair, `fleet.verify_pair`, the function the processes of `--jobs`
run, so a pair's outcome does not depend on where it ran (base/cluster.py: paths travel, never data; a
worker that dies costs a retry). A task carries absolute paths (or URLs) and the sha256 of each file as the
client reads it: a worker started in another folder, or on a machine with other copies, fails the pair instead
of judging its own files. Outcomes are put in manifest order; a pair whose workers kept dying is an "error"
outcome of its own, the others are verified.
"""
from __future__ import annotations

import os
import time
from dataclasses import replace
from functools import partial

from thermoplc.base.cluster import Lost, connect
from thermoplc.base.deadline import within
from thermoplc.base.locations import is_url
from thermoplc.verifier.fleets.pair import Outcome, Pair, verify_pair

HASHING_S = 10 ** 7  # no limit on hashing a pair's files (a year of CSV takes seconds); the wait only lets Ctrl-C in


def pinned(pair: Pair) -> Pair | None:
    """The pair as a task carries it: every file by its absolute path (a URL as given) with its sha256 here;
    None when a file cannot be read here (the pair is then verified here, which says why as one process would)."""
    from thermoplc.recordings.table import sha256_of
    where = {f: f if is_url(f) else os.path.abspath(f) for f in (pair.block, pair.data, pair.model) if f}
    try:
        digests = tuple((path, sha256_of(path)) for path in dict.fromkeys(where.values()))
    except OSError:
        return None
    return replace(pair, block=where[pair.block], data=where[pair.data],
                   model=where[pair.model] if pair.model else None, sha256=digests)


def verify_on_cluster(pairs: list[Pair], engine: str, scheduler: str) -> tuple[list[Outcome], float]:
    """Outcomes in manifest order from the cluster at `scheduler`, and the wall time of the whole fleet."""
    started = time.perf_counter()
    cluster = connect(scheduler)
    try:
        # each pair hashed on a thread of its own that Ctrl-C abandons (a FIFO or /dev/zero as data never ends)
        tasks = [within(HASHING_S, partial(pinned, pair), f"the files of manifest line {pair.line}") for pair in pairs]
        outcomes: list[Outcome | None] = [None if task else verify_pair(pair, engine)
                                          for pair, task in zip(pairs, tasks)]
        sent = [k for k, task in enumerate(tasks) if task]
        for j, result in cluster.run(partial(verify_pair, engine=engine), [tasks[k] for k in sent], "pair",
                                     [f"the pair of manifest line {pairs[k].line}" for k in sent]):
            k = sent[j]
            outcomes[k] = (Outcome(pairs[k], "error", str(result), str(result)) if isinstance(result, Lost)
                           else replace(result, pair=pairs[k]))
        return [o for o in outcomes if o is not None], time.perf_counter() - started
    finally:
        cluster.close()
