"""Where a recording is: a file path, or an object-store URL that pyarrow's filesystems read (s3://, gs://,
abfs://, hdfs://, file://).

A URL is read where the command runs, so on a Dask cluster each worker reads its runs from the store itself and
nothing passes through the scheduler. Credentials, region and endpoint come from the store's own environment as
pyarrow reads it (for S3: AWS_ACCESS_KEY_ID, AWS_SECRET_ACCESS_KEY, AWS_DEFAULT_REGION, and AWS_ENDPOINT_URL for
a MinIO or another S3-compatible store). Blocks, model files and outputs stay files.
"""
from __future__ import annotations

import errno
import io
import re
from typing import BinaryIO

URL = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*://")


def is_url(location: str) -> bool:
    return bool(URL.match(str(location)))


def name(location: str) -> str:
    """The last part of a URL or a path: a run's name in tables."""
    return str(location).rstrip("/").rsplit("/", 1)[-1]


def _unreadable(exc: Exception) -> OSError:
    """A store's refusal as the OSError a file's would be: its first line as the reason."""
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    return OSError(getattr(exc, "errno", None) or errno.EIO, re.sub(r"^\[Errno \d+\] ", "", text))


def _store(location: str):
    """(pyarrow filesystem, path inside it) of a URL; OSError when no filesystem reads it."""
    try:
        import pyarrow.fs as pafs
        return pafs.FileSystem.from_uri(location)
    except Exception as exc:  # ArrowInvalid for an unknown scheme, OSError for a store it cannot reach
        raise _unreadable(exc) from None


def open_binary(location: str) -> BinaryIO:
    """The recording's bytes as a buffered, seekable binary file; OSError as `open` raises it."""
    if not is_url(location):
        return open(location, "rb")
    store, path = _store(location)
    try:
        return io.BufferedReader(store.open_input_file(path), buffer_size=1 << 20)
    except Exception as exc:
        raise _unreadable(exc) from None


def size(location: str) -> int:
    """Bytes of the recording; OSError when it is not there."""
    if not is_url(location):
        import os
        return os.stat(location).st_size
    store, path = _store(location)
    try:
        info = store.get_file_info(path)
    except Exception as exc:
        raise _unreadable(exc) from None
    if info.size is None:
        raise OSError(errno.ENOENT, "no object there")
    return info.size


def listing(location: str, suffixes: tuple[str, ...]) -> list[str] | None:
    """The URLs of the objects directly under a URL that names a folder (a prefix), whose names end in one of
    `suffixes` (any case) and do not start with '.', by name; None when the URL names no folder."""
    import pyarrow.fs as pafs
    store, path = _store(location)
    try:
        if store.get_file_info(path).type != pafs.FileType.Directory:
            return None
        found = store.get_file_info(pafs.FileSelector(path, recursive=False))
    except Exception as exc:
        raise _unreadable(exc) from None
    base = location.rstrip("/")
    return sorted(f"{base}/{info.base_name}" for info in found
                  if info.type == pafs.FileType.File and info.base_name.lower().endswith(suffixes)
                  and not info.base_name.startswith("."))
