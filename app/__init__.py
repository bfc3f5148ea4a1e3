"""thermoplc: thermal-error models for machine tools, compiled to bit-exact PLC function blocks."""
import os
import platform

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
    if {"avx2", "fma"} <= flags:
        os.environ.setdefault("OPENBLAS_CORETYPE", "Haswell")


_pin_blas_kernels()

from thermoplc.base.version import __version__  # noqa: E402,F401  (after the BLAS settings)
