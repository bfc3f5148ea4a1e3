""".npz: columns stored with numpy.savez (one 1-D array per column), read whole or member by member."""
from __future__ import annotations

import os
import zipfile

from thermoplc.base.errors import UserError, unreadable
from thermoplc.base.locations import open_binary
from thermoplc.recordings.formats.definition import CannotStream, InputFormat


def read_columns(path: str, sparse: frozenset, gaps: bool) -> dict:
    """Columns stored with numpy.savez: the fast way in for very long recordings."""
    import numpy as np

    from thermoplc.recordings.cells import GAP_HINT

    try:
        with open_binary(path) as f:
            magic = f.read(4)
    except OSError as exc:
        raise unreadable(path, exc) from None
    if magic != b"PK\x03\x04":
        raise UserError(f"{path}: not a .npz archive (it does not start as a zip file); a CSV file must not end in .npz")
    try:
        with open_binary(path) as f, zipfile.ZipFile(f) as archive:
            unpacked = sum(info.file_size for info in archive.infolist())
    except (OSError, zipfile.BadZipFile) as exc:
        raise UserError(f"{path}: cannot read as .npz: {exc}") from None
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    if 2 * unpacked > memory:  # the columns are held as float64: up to twice the stored size
        raise UserError(f"{path}: the archive unpacks to {unpacked / 2 ** 30:.1f} GiB; this machine has "
                        f"{memory / 2 ** 30:.1f} GiB of memory (a zip bomb, or split the recording)")
    try:
        with open_binary(path) as f, np.load(f, allow_pickle=False) as archive:
            columns = {name: np.asarray(archive[name]) for name in archive.files}
    except (OSError, ValueError) as exc:
        raise UserError(f"{path}: cannot read as .npz: {exc}") from None
    if not columns:
        raise UserError(f"{path}: the archive holds no columns")
    lengths = {name: a.shape for name, a in columns.items()}
    if any(len(shape) != 1 for shape in lengths.values()) or len({s[0] for s in lengths.values()}) != 1:
        raise UserError(f"{path}: every array must be one column of the same length; found "
                        + ", ".join(f"{n} {s}" for n, s in lengths.items()))
    for name, a in columns.items():
        if a.dtype.kind not in "biuf":  # bool: the natural type of a recorded Enable or Reset
            raise UserError(f"{path}: column {name!r} holds {a.dtype}, expected numbers")
        columns[name] = a.astype(np.float64)
        bad = np.nonzero(~np.isfinite(columns[name]) & ~(np.isnan(columns[name]) & (name in sparse or gaps)))[0]
        if len(bad):
            raise UserError(f"{path}: column {name!r} row {bad[0] + 1}: expected a finite number, found {a[bad[0]]}"
                            f"{GAP_HINT if np.isnan(columns[name][bad[0]]) else ''}")
    if not len(next(iter(columns.values()))):
        raise UserError(f"{path}: no data rows")
    return columns


def _npy_header(member) -> tuple:
    """The shape and dtype of one member of the archive, read from its header."""
    import numpy as np

    version = np.lib.format.read_magic(member)
    if version == (1, 0):
        shape, fortran, dtype = np.lib.format.read_array_header_1_0(member)
    elif version == (2, 0):
        shape, fortran, dtype = np.lib.format.read_array_header_2_0(member)
    else:
        raise CannotStream(f"npy format {version}")
    if dtype.hasobject or dtype.kind not in "iuf" or len(shape) != 1:
        raise CannotStream("not a column of numbers")
    return shape, dtype


def read_chunks(path: str, rows_per_chunk: int):
    """The archive's columns, chunk by chunk, read from each member in turn (no member is unpacked whole)."""
    import numpy as np

    with open_binary(path) as f:
        if f.read(4) != b"PK\x03\x04":
            raise CannotStream("not a zip file")
    with open_binary(path) as f, zipfile.ZipFile(f) as archive:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        if 2 * sum(info.file_size for info in archive.infolist()) > memory:
            raise CannotStream("larger than memory")
        members = {}
        try:
            for info in archive.infolist():
                if not info.filename.endswith(".npy"):
                    raise CannotStream("not an array")
                member = archive.open(info)
                members[info.filename[:-4]] = (member, *_npy_header(member))
            if not members or len({shape for _, shape, _ in members.values()}) != 1:
                raise CannotStream("columns of different lengths")
            rows = next(iter(members.values()))[1][0]
            if rows == 0:
                raise CannotStream("no data rows")
            for start in range(0, rows, rows_per_chunk):
                n = min(rows_per_chunk, rows - start)
                columns = {}
                for name, (member, _, dtype) in members.items():
                    raw = member.read(n * dtype.itemsize)
                    if len(raw) != n * dtype.itemsize:
                        raise CannotStream("truncated array")
                    columns[name] = np.frombuffer(raw, dtype)
                yield columns
        finally:
            for member, *_ in members.values():
                member.close()


FORMAT = InputFormat(name="npz", suffix=".npz", title=".npz", rank=0, columns=read_columns, chunks=read_chunks)
