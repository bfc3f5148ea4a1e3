"""Parquet: a columnar file read with pyarrow, whole or record batch by record batch."""
from __future__ import annotations

from thermoplc.base.errors import UserError
from thermoplc.base.locations import open_binary
from thermoplc.recordings.formats.definition import CannotStream, InputFormat


def read_columns(path: str, sparse: frozenset, gaps: bool) -> dict:
    """Columns of a Parquet file (pyarrow): numbers only, no empty cells but in the `sparse` columns."""
    import numpy as np

    from thermoplc.recordings.cells import GAP_HINT

    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise UserError(f"{path}: reading Parquet needs pyarrow (pip install pyarrow)") from None
    try:
        with open_binary(path) as f:
            # no thread pool: read from a Python file on its threads, pyarrow aborts or hangs at the interpreter's
            # exit in some runs (apache/arrow#34314, #50482; here 1 run in 3 to 6 ended 'terminate called ...')
            table = pq.read_table(f, use_threads=False)
    except Exception as exc:  # OSError, and pyarrow's own errors for what is no Parquet file
        raise UserError(f"{path}: cannot read as Parquet: {exc}") from None
    if table.num_columns == 0:
        raise UserError(f"{path}: the file holds no columns")
    if table.num_rows == 0:
        raise UserError(f"{path}: no data rows")
    columns = {}
    for name in table.column_names:
        column = table.column(name)
        if column.null_count and name not in sparse and not gaps:
            row = int(np.flatnonzero(column.is_null().to_numpy(zero_copy_only=False))[0])
            raise UserError(f"{path}: column {name!r} row {row + 1}: expected a finite number, found an empty cell"
                            f"{GAP_HINT}")
        a = column.to_numpy()
        if a.dtype.kind not in "iuf":
            raise UserError(f"{path}: column {name!r} holds {column.type}, expected numbers")
        columns[name] = a.astype(np.float64)
        bad = np.nonzero(~np.isfinite(columns[name]) & ~(np.isnan(columns[name]) & (name in sparse or gaps)))[0]
        if len(bad):
            raise UserError(f"{path}: column {name!r} row {bad[0] + 1}: expected a finite number, found {a[bad[0]]!r}"
                            f"{GAP_HINT if np.isnan(columns[name][bad[0]]) else ''}")
    return columns


def read_chunks(path: str, rows_per_chunk: int):
    """The file's record batches as columns; an empty cell is left to `read_columns`, which names it."""
    import pyarrow.parquet as pq

    with open_binary(path) as f, pq.ParquetFile(f, pre_buffer=False, buffer_size=1 << 20) as pf:
        if pf.metadata.num_rows == 0:
            raise CannotStream("no data rows")
        for batch in pf.iter_batches(batch_size=rows_per_chunk, use_threads=False):
            if any(c.null_count for c in batch.columns):
                raise CannotStream("an empty cell")
            yield {n: batch.column(n).to_numpy(zero_copy_only=False) for n in batch.schema.names}


FORMAT = InputFormat(name="parquet", suffix=".parquet", title="Parquet", rank=1, columns=read_columns, chunks=read_chunks)
