"""A blocking call to another machine, given a limit in wall time and left at once on Ctrl-C.

pyarrow's filesystems and Dask's client block in native code or in a loop of their own: a peer that accepts
and never answers held a command for minutes, deaf to Ctrl-C (Python runs a signal's handler only between its
own bytecodes, in the main thread). Here the call runs on a thread of its own while the caller waits for it in
short slices: the caller is free at the limit or on Ctrl-C, and the abandoned thread, a daemon, ends with its
call or with the process. A caller on another thread (the one that reads the next block ahead) learns of Ctrl-C
through `interrupted`, which the program's SIGINT handler calls, so that the main thread, which joins it on its
way out, is not held until the store answers.
"""
from __future__ import annotations

import errno
import threading
import time
from typing import Callable, TypeVar

T = TypeVar("T")
POLL_S = 0.1  # how late a waiting thread learns of Ctrl-C
_interrupts = 0  # Ctrl-Cs so far: a wait ends at the first one after it began


def interrupted() -> None:
    """Ctrl-C: every wait of `within` in progress, on any thread, ends now."""
    global _interrupts
    _interrupts += 1


def within(seconds: float, call: Callable[[], T], what: str) -> T:
    """call()'s result or exception, or TimeoutError (its strerror 'no answer from `what` within `seconds` s',
    as a reader's messages quote an OSError) when it has not returned by then; on Ctrl-C an OSError ECANCELED
    (EINTR would be retried by Python's buffered files), though in the main thread the handler's KeyboardInterrupt
    comes first."""
    done = threading.Event()
    outcome: list = []

    def run() -> None:
        try:
            outcome.append((call(), None))
        except BaseException as exc:  # handed to the caller, raised there
            outcome.append((None, exc))
        finally:
            done.set()

    interrupts, end = _interrupts, time.monotonic() + seconds
    threading.Thread(target=run, name="thermoplc-remote-call", daemon=True).start()
    while not done.wait(min(POLL_S, max(0.0, end - time.monotonic()))):
        if _interrupts != interrupts:
            raise OSError(errno.ECANCELED, f"interrupted while waiting for {what}")
        if time.monotonic() >= end:
            raise TimeoutError(errno.ETIMEDOUT, f"no answer from {what} within {seconds:g} s")
    result, error = outcome[0]
    if error is not None:
        raise error
    return result
