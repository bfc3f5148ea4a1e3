"""The switch between compiled (numba) and pure numpy/Python loops, and numba loaded on first use.

The references' per-call loops (each kind's, models/kernels.py's) are written once, as Python numba can compile
(`jit`), and run compiled or as Python (`route`); the CSV parser (recordings/plain_csv) and the simulation's lags
(physics/) keep a numpy route beside their numba one. They all compile with the same house options (fast-math off)
and obey one switch: THERMOPLC_REFERENCE (auto | fast | slow) or `reference()`; `enabled()` decides per request, so
a short verify never loads numba. Both routes give the same bits (tests/test_fast_reference.py)."""
from __future__ import annotations

import contextlib
import importlib
import importlib.util
import os


MODES = ("auto", "fast", "slow")
_mode = os.environ.get("THERMOPLC_REFERENCE", "auto")
# numba, its LLVM and the cached machine code of these loops take about 0.45 s to load in a process: as long as the
# numpy loops take for some 400,000 calls (a Kalman block's verify asks for about 12 per recorded row: two
# precisions, the estimate, one guard per input, the limiter; the numpy loops run 24 h at 10 s in 0.1 s). A process
# takes the compiled loops once it has asked for this many calls in all: a short verify never loads numba, a fit
# does after a few dozen evaluations.
COMPILED_AFTER_CALLS = 400_000
_asked = 0
_numba = None
_numba_error = None


def _load_numba():
    """numba, imported on first use (None when it cannot be)."""
    global _numba, _numba_error
    if _numba is None and _numba_error is None:
        try:
            _numba = importlib.import_module("numba")
        except Exception as exc:  # pragma: no cover - exercised only on a broken install
            _numba_error = str(exc)
    return _numba


def available() -> bool:
    """numba is installed (found, not imported)."""
    return _numba is not None or (_numba_error is None and importlib.util.find_spec("numba") is not None)


def could_compile() -> bool:
    """The compiled loops may be used: numba is installed and THERMOPLC_REFERENCE is not 'slow'."""
    return _mode != "slow" and available()


def enabled(calls: int = COMPILED_AFTER_CALLS) -> bool:
    """True when the compiled loops compute the reference for the next `calls` calls: always in mode 'fast', never in
    'slow' or without numba, and in 'auto' once the process has asked for `COMPILED_AFTER_CALLS` calls in all. Both
    give the same bits (tests/test_fast_reference.py); only the time differs."""
    global _asked
    if not could_compile():
        return False
    _asked += calls
    return (_mode == "fast" or _asked >= COMPILED_AFTER_CALLS) and _load_numba() is not None


def route(loop, calls: int):
    """`loop` (a `jit` function) compiled when `enabled(calls)`, else as the Python it was written in: one source,
    two ways to run it, the same bits."""
    return loop if enabled(calls) else getattr(loop, "py_func", loop)


@contextlib.contextmanager
def reference(which: str):
    """Compute the reference with the compiled loops ('fast'), the numpy/Python loops ('slow') or as the process's
    calls decide ('auto')."""
    global _mode
    if which not in MODES:
        raise ValueError(f"reference must be one of {MODES}, got {which!r}")
    before, _mode = _mode, which
    try:
        yield
    finally:
        _mode = before


JIT_OPTIONS = dict(cache=True, fastmath=False, error_model="numpy", nogil=True, boundscheck=False)


def njit(fn):
    """`fn` as numba.njit compiles it with the house options: fast-math off, the machine code cached on disk where a
    folder is writable (else compiled in every process). Imports numba."""
    numba = _load_numba()
    try:
        return numba.njit(**JIT_OPTIONS)(fn)
    except RuntimeError:  # no writable cache folder anywhere
        return numba.njit(**{**JIT_OPTIONS, "cache": False})(fn)


class _Compiled:
    """`fn` compiled by numba.njit with the house options (fast-math off, cached on disk) on its first call, so
    importing these loops loads no numba."""

    def __init__(self, fn):
        self.py_func = fn
        self._dispatcher = None

    @property
    def dispatcher(self):
        if self._dispatcher is None:
            self._dispatcher = njit(self.py_func)
        return self._dispatcher

    def __call__(self, *args):
        return self.dispatcher(*args)

    @property
    def signatures(self):
        return self.dispatcher.signatures


def jit(fn):
    """`fn` compiled on first use (`_Compiled`); `fn` itself without numba."""
    return _Compiled(fn) if available() else fn


def __getattr__(attribute: str):
    """`numba`: the module, imported on first use (PEP 562); None when it is missing."""
    if attribute == "numba":
        return _load_numba() if available() else None
    raise AttributeError(f"module {__name__!r} has no attribute {attribute!r}")
