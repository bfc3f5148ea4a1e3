"""read_ahead: a generator run one step ahead on a thread gives the same items, raises where it raised,
holds at most AHEAD items beyond the caller, and stops (closing the generator) when the caller stops."""
from __future__ import annotations

import threading
import time

import pytest

from thermoplc.recordings import read_ahead as ahead


def test_the_same_items_in_the_same_order():
    assert list(ahead.read_ahead(lambda: iter(range(1000)))) == list(range(1000))


def test_an_error_reaches_the_caller_after_the_items_before_it():
    def failing():
        yield 1
        yield 2
        raise ValueError("bad block")

    got = []
    with pytest.raises(ValueError, match="bad block"):
        for item in ahead.read_ahead(failing):
            got.append(item)
    assert got == [1, 2]


def test_a_caller_that_stops_early_stops_and_closes_the_generator():
    made, closed = [], threading.Event()

    def blocks():
        try:
            for k in range(10_000):
                made.append(k)
                yield k
        finally:
            closed.set()

    items = ahead.read_ahead(blocks)
    assert next(items) == 0
    time.sleep(0.2)  # the thread runs ahead as far as it may
    assert len(made) <= 1 + ahead.AHEAD + 1  # the one taken, those waiting, the one being put
    items.close()
    assert closed.wait(5) and len(made) < 10
