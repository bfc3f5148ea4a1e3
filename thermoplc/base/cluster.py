"""Independent tasks run in this process or on a Dask distributed cluster (`--scheduler tcp://HOST:PORT`).

Dask is the engine (the `fleet` extra); nothing here schedules. A caller hands a module-level function and its
items (file paths and small requests, never the data: every worker reads the files as the client does) and
gets the results back by index, whatever order they finish in. A worker that dies mid-task costs a retry: the
scheduler gives the task to another worker (up to `distributed.scheduler.allowed-failures` deaths, then the
task is lost and the caller says what that means), and each task has one slot, so none is counted twice.

A result must not depend on where it ran, so every worker's answer carries its environment (thermoplc's
sources (every file of the package folder), the numeric libraries, the BLAS kernels, which fix a fit's last bits)
and one that differs from the client's is refused by name instead of mixed in.

Connecting is bounded in wall time: what listens at the address must answer Dask's handshake as a scheduler
within `CONNECT_TIMEOUT_S` before a Client is made, all of it asked on a thread of its own (base/deadline.py), so
that Ctrl-C is honoured at once and no half-built Client is left to a finaliser.
"""
from __future__ import annotations

import hashlib
import importlib.util
import logging
import platform
import socket
import sys
import threading
import time
import uuid
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Callable, Iterator

from thermoplc.base.deadline import within
from thermoplc.base.errors import ClusterError, UserError

CONNECT_TIMEOUT_S = 20
POLL_S = 2  # how often the cluster is asked whether it still has workers
SOURCE_SUFFIXES = (".py", ".lark", ".json", ".j2")
NUMERIC_LIBRARIES = ("numpy", "scipy", "numba", "pyarrow")

# glibc's mallopt parameters: the nanny starts each worker with MALLOC_TRIM_THRESHOLD_=65536 (to hand memory back
# to the system), which also fixes glibc's mmap threshold at 128 KiB: every column of a chunk is then a fresh
# mmap, zeroed page by page (a machine-month took 0.90 s on a worker against 0.44 s in a process of --jobs)
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
CHUNK_HEAP_BYTES = 32 << 20  # glibc's largest mmap threshold: a chunk's columns (1 M rows of float64) fit below


class Lost(Exception):
    """A task the cluster could not finish: its workers died `allowed-failures` times."""


@lru_cache(maxsize=1)
def environment() -> tuple[tuple[str, str], ...]:
    """What a numeric result depends on besides its inputs: the digest of thermoplc's own files, the Python and
    library versions, and the kernels OpenBLAS chose (thermoplc/__init__.py pins them where it can)."""
    digest = hashlib.sha256()
    package = Path(importlib.util.find_spec("thermoplc").origin).parent
    for path in sorted(package.rglob("*")):
        if path.suffix in SOURCE_SUFFIXES and path.is_file() and "__pycache__" not in path.parts:
            digest.update(f"{path.relative_to(package).as_posix()}\0".encode() + path.read_bytes())
    found = [("thermoplc sources", digest.hexdigest()[:16]), ("python", platform.python_version())]
    for name in NUMERIC_LIBRARIES:
        module = sys.modules.get(name) or importlib.import_module(name)
        found.append((name, getattr(module, "__version__", "?")))
    found.append(("BLAS kernels", _blas_kernels()))
    return tuple(found)


def _blas_kernels() -> str:
    """The core type OpenBLAS runs its kernels for, read from the library numpy loaded."""
    import ctypes
    import numpy  # noqa: F401  (loads its BLAS)
    try:
        with open("/proc/self/maps", encoding="ascii", errors="replace") as maps:
            libraries = sorted({line.split()[-1] for line in maps if "openblas" in line.lower() and "/" in line})
    except OSError:
        return "unknown"
    for library in libraries:
        for symbol in ("scipy_openblas_get_corename64_", "openblas_get_corename64_", "openblas_get_corename"):
            function = getattr(ctypes.CDLL(library), symbol, None)
            if function is not None:
                function.restype = ctypes.c_char_p
                return function().decode("ascii", "replace")
    return "unknown"


def _heap_for_chunks() -> None:
    """Let this worker's allocator reuse freed memory for the next chunk's columns, as a plain process does."""
    import ctypes
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None)
        libc.mallopt(M_MMAP_THRESHOLD, CHUNK_HEAP_BYTES)
        libc.mallopt(M_TRIM_THRESHOLD, 4 * CHUNK_HEAP_BYTES)
    except (OSError, AttributeError):  # not glibc: its own allocator's defaults
        pass


def on_worker(function: Callable, item) -> tuple[tuple, str, object]:
    """`function(item)` on a Dask worker, its allocator set as a plain process's is, with the worker's
    environment and address beside the result."""
    _heap_for_chunks()
    try:
        from distributed import get_worker
        where = get_worker().address
    except (ImportError, ValueError):
        where = "this process"
    return environment(), where, function(item)


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
    """Refuse at once an address nothing answers at (an unknown host, a refused connection)."""
    host, _, port = scheduler.removeprefix("tcp://").rpartition(":")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise _unreachable(scheduler, exc) from None


def _identity(scheduler: str) -> object:
    """What the server at `scheduler` says it is, asked as a Client asks: Dask's handshake, then `identity`.
    Bounded here too (just after the caller's limit), so that the thread it runs on ends."""
    import asyncio
    from distributed.comm import connect as open_comm

    async def ask() -> object:
        comm = await open_comm(scheduler, timeout=CONNECT_TIMEOUT_S)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    return asyncio.run(asyncio.wait_for(ask(), CONNECT_TIMEOUT_S + 1))


def _client(distributed, scheduler: str):
    """A Client of the Dask scheduler at `scheduler`, made only once the server there has answered as one: a
    Client of a server that never answers waited past 300 s (Dask's handshake has no limit), and one of a server
    that answers garbage failed half-built, its finaliser waiting 40 s more to print a traceback at exit."""
    _reachable(scheduler)
    try:
        reply = _identity(scheduler)
    except Exception:  # garbage read as Dask's frames: "Unable to allocate 6.09 EiB", a bad message, a reset
        reply = None
    if not (isinstance(reply, dict) and reply.get("type") == "Scheduler"):
        raise _unreachable(scheduler, "what answers there is not a Dask scheduler")
    return distributed.Client(scheduler, timeout=CONNECT_TIMEOUT_S, set_as_default=False)


@dataclass
class Cluster:
    """A connection to the scheduler at `address`; `run` maps a function over items on its workers."""
    address: str
    client: object
    distributed: object

    def run(self, function: Callable, items: list, what: str, names: list[str] | None = None
            ) -> Iterator[tuple[int, object]]:
        """(index, result) of each item as it finishes; `Lost` in place of a result whose workers kept dying.
        `what` names the items in task keys ("fold", "candidate", "pair"), `names` each in messages."""
        run = uuid.uuid4().hex  # task keys of this call alone, beside any other client's on the same cluster
        futures = [self.client.submit(on_worker, function, item, pure=False, key=f"thermoplc-{what}-{k}-{run}")
                   for k, item in enumerate(items)]  # submitted now: the caller may work while they run
        return self._results(futures, what, names)

    def _results(self, futures: list, what: str, names: list[str] | None) -> Iterator[tuple[int, object]]:
        slot = {future.key: k for k, future in enumerate(futures)}
        starved = threading.Event()
        watcher = threading.Thread(target=self._watch, args=(futures, starved), daemon=True)
        watcher.start()
        done = 0
        try:
            for future in self.distributed.as_completed(futures, loop=self.client.loop):
                k = slot[future.key]
                name = names[k] if names else f"{what} {k + 1}"
                if starved.is_set():
                    raise ClusterError(f"--scheduler {self.address}: no worker left for {CONNECT_TIMEOUT_S} s; {done} of "
                                       f"{len(futures)} were done; nothing written (start workers with `dask worker "
                                       f"{self.address}`)")
                yield k, self._result(future, name, done, len(futures))
                done += 1
        finally:
            starved.set()  # ends the watcher too
            for future in futures:
                try:
                    future.cancel()
                except Exception:  # the client already closed (the scheduler gone): nothing left to cancel
                    pass

    def _watch(self, futures: list, starved: threading.Event) -> None:
        """Every `POLL_S`: a cluster without a worker for `CONNECT_TIMEOUT_S` cancels the tasks (the loop over
        them then says why in one line); a scheduler gone cancels them itself."""
        idle_since = None
        while not starved.wait(POLL_S):
            try:
                workers = self.client.scheduler_info()["workers"]
            except Exception:
                return
            if workers:
                idle_since = None
                continue
            idle_since = idle_since or time.monotonic()
            if time.monotonic() - idle_since > CONNECT_TIMEOUT_S:
                starved.set()
                try:
                    self.client.cancel(futures)
                except Exception:
                    pass
                return

    def _result(self, future, name: str, done: int, total: int):
        """A finished task's result, `Lost` when its workers kept dying; the task's own error as in one process."""
        distributed = self.distributed
        try:
            found, where, result = future.result()
        except distributed.KilledWorker as exc:
            return Lost(f"the workers running it died: {exc}")
        except Exception as exc:
            if future.status == "error":
                raise  # the task's own exception, as in one process
            raise ClusterError(f"--scheduler {self.address}: the cluster lost {name} ({_first_line(exc)}); {done} of "
                               f"{total} were done; nothing written") from None
        _same_environment(found, where, self.address)
        return result

    def close(self) -> None:
        self.client.close()


def _first_line(exc: Exception) -> str:
    return f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else 'no message'}"


def _same_environment(found: tuple, where: str, address: str) -> None:
    ours = environment()
    if found != ours:
        differ = {name: (theirs, mine) for (name, theirs), (_, mine) in zip(found, ours) if theirs != mine}
        listed = "; ".join(f"{name} {theirs} there, {mine} here" for name, (theirs, mine) in differ.items())
        raise ClusterError(f"--scheduler {address}: worker {where} does not run what this client runs ({listed}): its "
                           f"results could differ in their last bits; {_remedy(differ, address)}")


def _remedy(differ: dict, address: str) -> str:
    """How to make a worker run what this client runs: the same installation, and OpenBLAS told which kernels
    (it picks them by CPU, and a `dask worker` has loaded numpy before thermoplc could pin them)."""
    install = "install the same thermoplc and libraries there"
    kernels = differ.get("BLAS kernels", (None, "unknown"))[1]
    if kernels == "unknown":
        return install
    pin = (f"set OPENBLAS_CORETYPE={kernels} (this client's kernels) on both sides for the same kernels: "
           f"`OPENBLAS_CORETYPE={kernels} dask worker {address}`")
    return pin if set(differ) == {"BLAS kernels"} else f"{install}; {pin}"


def connect(scheduler: str) -> Cluster:
    """The cluster at `scheduler`, with at least one worker, or a one-line UserError."""
    distributed = _distributed()
    for name in ["distributed", *logging.root.manager.loggerDict]:  # its tracebacks on stderr: we say it in one line
        if name.startswith("distributed"):
            logging.getLogger(name).setLevel(logging.CRITICAL)
    try:  # on a thread of its own: Ctrl-C at any moment, and CONNECT_TIMEOUT_S for all of it
        client = within(CONNECT_TIMEOUT_S, lambda: _client(distributed, scheduler), "the scheduler")
    except UserError:
        raise
    except TimeoutError:
        raise _unreachable(scheduler, f"no answer within {CONNECT_TIMEOUT_S} s") from None
    except Exception as exc:
        raise _unreachable(scheduler, exc) from None
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
    except TimeoutError:
        client.close()
        raise UserError(f"--scheduler {scheduler}: the scheduler has no worker after {CONNECT_TIMEOUT_S} s; start "
                        f"some with `dask worker {scheduler}`") from None
    return Cluster(scheduler, client, distributed)


def run_all(function: Callable, items: list, what: str, cluster: Cluster | None) -> Iterator[tuple[int, object]]:
    """(index, result) of every item: in this process in order, or on `cluster` as they finish."""
    if cluster is None:
        return ((k, function(item)) for k, item in enumerate(items))
    return cluster.run(function, items, what)
