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

from thermoplc.base.errors import UserError

URL = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*://")


def is_url(location: str) -> bool:
    return bool(URL.match(str(location)))


def _parts(location: str) -> tuple[str, str, str]:
    """(scheme://authority, the path below it as written, '?query' or '') of a URL."""
    head, mark, query = location.partition("?")
    scheme, _, rest = head.partition("://")
    authority, _, path = rest.partition("/")
    return f"{scheme}://{authority}", path, mark + query


def name(location: str) -> str:
    """The last part of a URL (without its query) or a path: a run's name in tables, its suffix its format."""
    if is_url(location):
        root, path, _ = _parts(location)
        location = f"{root}/{path}"
    return str(location).rstrip("/").rsplit("/", 1)[-1]


def _unreadable(exc: Exception) -> OSError:
    """A store's refusal as the OSError a file's would be: its first line as the reason."""
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    return OSError(getattr(exc, "errno", None) or errno.EIO, re.sub(r"^\[Errno \d+\] ", "", text))


GCS_RETRY_S = 20  # pyarrow's Google Cloud Storage client retries for 15 min by default, deaf to Ctrl-C meanwhile


def _store(location: str):
    """(pyarrow filesystem, path inside it) of a URL, the path as written (spaces and any letters, no
    percent-encoding); OSError when no filesystem reads it."""
    root, path, query = _parts(location)
    try:
        import pyarrow.fs as pafs
        if root.startswith("gs://") or root.startswith("gcs://"):
            import datetime
            store = pafs.GcsFileSystem(retry_time_limit=datetime.timedelta(seconds=GCS_RETRY_S))
            return store, f"{root.split('://', 1)[1]}/{path}".rstrip("/")
        store, base = pafs.FileSystem.from_uri(root + "/" + query)
    except Exception as exc:  # ArrowInvalid for an unknown scheme, OSError for a store it cannot reach
        raise _unreadable(exc) from None
    return store, f"{base.rstrip('/')}/{path}".rstrip("/") if path else base


class _StoreFile(io.RawIOBase):
    """A store's file as a Python raw file whose failures are OSErrors, as a local file's are (zipfile seeks
    before the start of a tiny object; pyarrow says ArrowInvalid, a file says OSError, which the readers catch)."""

    def __init__(self, native):
        self._native = native

    def _call(self, method, *args):
        try:
            return getattr(self._native, method)(*args)
        except Exception as exc:
            raise _unreadable(exc) from None

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        return self._call("readinto", buffer)

    def seek(self, offset: int, whence: int = 0) -> int:
        return self._call("seek", offset, whence)

    def tell(self) -> int:
        return self._call("tell")

    def close(self) -> None:
        if not self.closed:
            self._native.close()
        super().close()


def open_binary(location: str) -> BinaryIO:
    """The recording's bytes as a buffered, seekable binary file; OSError as `open` raises it."""
    if not is_url(location):
        return open(location, "rb")
    store, path = _store(location)
    try:
        return io.BufferedReader(_StoreFile(store.open_input_file(path)), buffer_size=1 << 20)
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
    root, below, query = _parts(location)
    base = f"{root}/{below}".rstrip("/")
    return sorted(f"{base}/{info.base_name}{query}" for info in found
                  if info.type == pafs.FileType.File and info.base_name.lower().endswith(suffixes)
                  and not info.base_name.startswith("."))


def refuse_as_output(location: str, what: str) -> None:
    """Outputs are files: a URL given for one would become a local folder named like the store."""
    if is_url(location):
        raise UserError(f"{location}: {what} is written to a file; object-store URLs are read, never written; give "
                        f"a file name")
