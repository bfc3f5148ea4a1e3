"""`verify --outputs FILE`: what the block output at each call of a replay, beside the recording's time, for a
commissioning engineer to plot against the measurement, hand to the NC team or compare with a PLC trace.

REAL outputs are written with 9 significant digits (or as float32 columns in Parquet): every binary32 value
reads back to the same bits, so `verify --expect` on a trace made of this file is bit-exact. BOOL as 0/1,
integers as integers."""
from __future__ import annotations

import csv
import io

import numpy as np

from thermoplc.base.errors import UserError

SUFFIXES = (".csv", ".parquet")


def check_name(path: str) -> None:
    if not path.lower().endswith(SUFFIXES):
        raise UserError(f"--outputs {path}: expected a file ending in .csv or .parquet")


def columns(produced: dict, times: np.ndarray, time_column: str) -> dict:
    """The time column (as the recording has it) and each output, in the block's order."""
    if time_column in produced:
        raise UserError(f"--outputs: the block has an output named like the time column {time_column!r}")
    return {time_column: np.asarray(times, np.float64), **{name: np.asarray(v) for name, v in produced.items()}}


def encoded(found: dict, path: str) -> bytes:
    """The file's bytes: CSV text, or a Parquet table when `path` ends in .parquet."""
    if path.lower().endswith(".parquet"):
        import pyarrow as pa
        import pyarrow.parquet as pq
        sink = io.BytesIO()
        pq.write_table(pa.table({name: pa.array(values) for name, values in found.items()}), sink)
        return sink.getvalue()
    names = list(found)
    cells = [_texts(found[name]) for name in names]
    header = io.StringIO()
    csv.writer(header, lineterminator="").writerow(names)  # a name with a comma or a quote stays one field
    lines = [header.getvalue()] + [",".join(row) for row in zip(*cells)]
    return ("\n".join(lines) + "\n").encode()


def _texts(values: np.ndarray) -> list[str]:
    if values.dtype == np.bool_:
        return ["1" if v else "0" for v in values]
    if np.issubdtype(values.dtype, np.integer):
        return [str(int(v)) for v in values]
    if values.dtype == np.float32:
        return [f"{float(v):.9g}" for v in values]
    return [repr(float(v)) for v in values]
