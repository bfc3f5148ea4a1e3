"""thermoplc: thermal-error models for machine tools, compiled to bit-exact PLC function blocks."""
import os

# The fits solve thousands of small least-squares problems; a threaded BLAS only spins on them
# and, beside a second process on the same cores, makes them several times slower. One thread
# unless the user says otherwise (set before numpy is first imported, which happens below us).
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

__version__ = "0.1.0"
