"""thermoplc: thermal-error models for machine tools, compiled to bit-exact PLC function blocks."""
import os
import platform
import sys
import warnings

# The fits solve thousands of small least-squares problems; a threaded BLAS only spins on them
# and, beside a second process on the same cores, makes them several times slower. One thread
# unless the user says otherwise (set before numpy is first imported, which happens below us).
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")


def _pin_blas_kernels() -> None:
    """OpenBLAS picks its kernels by CPU, and a fit's last float64 bits (so a model's fingerprint)
    follow them: the README's twin fitted to other bits on an AVX-512 server than on an AVX2 one
    with the same pinned numpy and scipy. Haswell's kernels run on every x86-64 CPU with AVX2 and
    FMA, so those CPUs all use them; the user's own OPENBLAS_CORETYPE wins."""
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as info:
            flags = set(next((line for line in info if line.startswith("flags")), "").split())
    except OSError:
        return
    if {"avx2", "fma"} <= flags and "OPENBLAS_CORETYPE" not in os.environ:
        os.environ["OPENBLAS_CORETYPE"] = "Haswell"
        if "numpy" in sys.modules:  # too late: OpenBLAS chose its kernels when numpy loaded
            warnings.warn("numpy was imported before thermoplc, so OpenBLAS chose this CPU's own kernels: a fit here "
                          "may differ in its last bits from `thermoplc fit`'s; import thermoplc first, or set "
                          "OPENBLAS_CORETYPE=Haswell", RuntimeWarning, stacklevel=3)


_pin_blas_kernels()

from thermoplc.base.version import __version__  # noqa: E402,F401  (after the BLAS settings)
