"""A generator run one step ahead on a thread, so reading the next block overlaps the work on this one.

`verify` streams a CSV block by block: the next block is parsed (recordings/plain_csv or pyarrow, on every core,
without the GIL) while the caller computes the references and replays the last one (numba and the compiled
block, also without the GIL). At most `AHEAD` items wait, so memory stays bounded; an error the generator raises reaches the caller
where the generator would have raised it; a caller that stops early (gives up, Ctrl-C) stops the thread,
which closes the generator (and its file) after the block it is on.
"""
from __future__ import annotations

import queue
import threading
from typing import Callable, Iterator, TypeVar

T = TypeVar("T")
AHEAD = 1
_END = object()


def read_ahead(make: Callable[[], Iterator[T]]) -> Iterator[T]:
    """The items of `make()`, produced on a thread of their own."""
    waiting: queue.Queue = queue.Queue(maxsize=AHEAD)
    stop = threading.Event()

    def put(item) -> bool:
        while not stop.is_set():
            try:
                waiting.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def produce() -> None:
        items = None
        try:
            items = make()
            for item in items:
                if not put((None, item)):
                    return
            put((None, _END))
        except BaseException as exc:  # handed to the caller, raised there
            put((exc, None))
        finally:
            if items is not None and hasattr(items, "close"):
                items.close()

    thread = threading.Thread(target=produce, name="thermoplc-read-ahead", daemon=True)
    thread.start()
    try:
        while True:
            error, item = waiting.get()
            if error is not None:
                raise error
            if item is _END:
                return
            yield item
    finally:
        stop.set()
        thread.join()
