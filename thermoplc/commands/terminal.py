"""Progress of a long command: a line redrawn in place on a terminal, plain timed lines in a log."""
from __future__ import annotations

import sys
import time
from typing import Callable

LOG_EVERY_S = 5.0  # in a log, at most one line this often, and none for a command done sooner


def _show(message: str) -> None:
    print(f"\r  {message:<70}", end="", file=sys.stderr, flush=True)


class _LogLines:
    """Where standard error is a file or a pipe (CI, a service log): no carriage returns, a line with
    the seconds elapsed every `LOG_EVERY_S`, so a long fit or diagnosis is visibly alive there too."""

    def __init__(self) -> None:
        self.last = self.start = time.monotonic()

    def __call__(self, message: str) -> None:
        now = time.monotonic()
        if now - self.last >= LOG_EVERY_S:
            self.last = now
            print(f"thermoplc: {now - self.start:.0f} s: {message}", file=sys.stderr, flush=True)


def progress() -> Callable[[str], None]:
    """The progress callback for the library: in place on a terminal, timed lines in a log."""
    return _show if sys.stderr.isatty() else _LogLines()


def end_progress() -> None:
    """Close the progress line so that what follows starts on a line of its own."""
    if sys.stderr.isatty():
        print(file=sys.stderr)
