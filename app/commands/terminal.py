"""The progress line a long command shows on a terminal (never in a log: no carriage returns there)."""
from __future__ import annotations

import sys
from typing import Callable


def _show(message: str) -> None:
    print(f"\r  {message:<70}", end="", file=sys.stderr, flush=True)


def progress() -> Callable[[str], None] | None:
    """The progress callback for the library, or None when standard error is not a terminal."""
    return _show if sys.stderr.isatty() else None


def end_progress() -> None:
    """Close the progress line so that what follows starts on a line of its own."""
    if sys.stderr.isatty():
        print(file=sys.stderr)
