"""verify --manifest on a Dask distributed cluster (`--scheduler tcp://HOST:PORT`): the pairs of a fleet as tasks.

Dask is the engine (the `fleet` extra); nothing here schedules. Each task is one whole (block, data, model)
pair, `fleet.verify_pair`, the function the processes of `--jobs` run, so a pair's outcome does not depend
on where it ran. What travels is the pair: file paths, which every worker must read as the client does (a
shared folder; the data are never pickled through the scheduler). Outcomes come back as they finish and are
put in manifest order. A worker that dies mid-pair costs a retry: the scheduler gives its tasks to another
worker (up to `distributed.scheduler.allowed-failures` deaths per task, then that pair is an error), and each
pair has one slot in the result, so none is lost or counted twice.
"""
from __future__ import annotations

import logging
import socket
import time
import uuid

from thermoplc.base.errors import UserError
from thermoplc.verifier.fleet import Outcome, Pair, verify_pair

CONNECT_TIMEOUT_S = 20


# glibc's mallopt parameters: the nanny starts each worker with MALLOC_TRIM_THRESHOLD_=65536 (to hand memory back
# to the system), which also fixes glibc's mmap threshold at 128 KiB: every column of a chunk is then a fresh
# mmap, zeroed page by page (a machine-month took 0.90 s on a worker against 0.44 s in a process of --jobs)
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
CHUNK_HEAP_BYTES = 32 << 20  # glibc's largest mmap threshold: a chunk's columns (1 M rows of float64) fit below


def _heap_for_chunks() -> None:
    """Let this worker's allocator reuse freed memory for the next chunk's columns, as a plain process does."""
    import ctypes
    import sys
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None)
        libc.mallopt(M_MMAP_THRESHOLD, CHUNK_HEAP_BYTES)
        libc.mallopt(M_TRIM_THRESHOLD, 4 * CHUNK_HEAP_BYTES)
    except (OSError, AttributeError):  # not glibc: its own allocator's defaults
        pass


def verify_on_worker(pair: Pair, engine: str) -> Outcome:
    """`fleet.verify_pair` on a Dask worker, its allocator set as a plain process's is."""
    _heap_for_chunks()
    return verify_pair(pair, engine)


def _distributed():
    try:
        import distributed
    except ImportError:
        raise UserError("--scheduler needs Dask distributed: pip install 'thermoplc[fleet]'") from None
    return distributed


def _unreachable(scheduler: str, why: object) -> UserError:
    return UserError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({why}); start one with "
                     f"`dask scheduler` and workers with `dask worker {scheduler}` (docs/performance.md)")


def _reachable(scheduler: str) -> None:
    """Refuse at once an address nothing answers at: a Client that fails half-built waits 40 s more on its way out."""
    host, _, port = scheduler.removeprefix("tcp://").rpartition(":")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise _unreachable(scheduler, exc) from None


def verify_on_cluster(pairs: list[Pair], engine: str, scheduler: str) -> tuple[list[Outcome], float]:
    """Outcomes in manifest order from the cluster at `scheduler`, and the wall time of the whole fleet."""
    distributed = _distributed()
    for name in ["distributed", *logging.root.manager.loggerDict]:  # its tracebacks on stderr: we say it in one line
        if name.startswith("distributed"):
            logging.getLogger(name).setLevel(logging.CRITICAL)
    started = time.perf_counter()
    _reachable(scheduler)
    try:
        client = distributed.Client(scheduler, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except Exception as exc:
        raise _unreachable(scheduler, exc) from None
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
    except TimeoutError:
        client.close()
        raise UserError(f"--scheduler {scheduler}: the scheduler has no worker after {CONNECT_TIMEOUT_S} s; start "
                        f"some with `dask worker {scheduler}`") from None
    run = uuid.uuid4().hex  # task keys of this fleet alone, beside any other client's on the same cluster
    try:
        futures = client.map(verify_on_worker, pairs, engine=engine, pure=False,
                             key=[f"thermoplc-verify-{pair.line}-{run}" for pair in pairs])
        slot = {future.key: k for k, future in enumerate(futures)}
        outcomes: list[Outcome | None] = [None] * len(pairs)
        for future in distributed.as_completed(futures, loop=client.loop):
            k = slot[future.key]
            try:
                outcomes[k] = future.result()
            except distributed.KilledWorker as exc:
                outcomes[k] = Outcome(pairs[k], "error", f"the workers running it died: {exc}", str(exc))
            except Exception as exc:  # the scheduler gone, the task cancelled: the fleet has no answer for it
                done = sum(o is not None for o in outcomes)
                raise UserError(f"--scheduler {scheduler}: the cluster lost the pair of manifest line {pairs[k].line} "
                                f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else 'no message'}); "
                                f"{done} of {len(pairs)} pairs were verified; nothing written") from None
        return [o for o in outcomes if o is not None], time.perf_counter() - started
    finally:
        client.close()
