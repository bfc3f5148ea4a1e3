"""Where a recording is: a file path, or an object-store URL that pyarrow's filesystems read (s3://, gs://,
abfs://, hdfs://, file://).

A URL is read where the command runs, so on a Dask cluster each worker reads its runs from the store itself and
nothing passes through the scheduler. Credentials, region and endpoint come from the store's own environment as
pyarrow reads it (for S3: AWS_ACCESS_KEY_ID, AWS_SECRET_ACCESS_KEY, AWS_DEFAULT_REGION, and AWS_ENDPOINT_URL for
a MinIO or another S3-compatible store). Blocks, model files and outputs stay files.

Each request to a store (opening it, an object's size, a folder's listing, one read of at most `READ_BYTES`) is
answered within `ANSWER_S` or ends as an OSError, after which that store is not asked again for `ANSWER_S`, and
Ctrl-C stops the wait at once (base/deadline.py): a store that accepts and never answers held a command for 200 s,
deaf to Ctrl-C for 97 of them.
"""
from __future__ import annotations

import errno
import io
import os
import re
import shutil
import time
from datetime import timedelta
from typing import BinaryIO, Callable, TypeVar

from thermoplc.base.deadline import within
from thermoplc.base.errors import UserError

T = TypeVar("T")

URL = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*://")


def is_url(location: str) -> bool:
    return bool(URL.match(str(location)))


def _parts(location: str) -> tuple[str, str, str]:
    """(scheme://authority, the path below it as written, '?query' or '') of a URL."""
    head, mark, query = location.partition("?")
    scheme, _, rest = head.partition("://")
    authority, _, path = rest.partition("/")
    return f"{scheme}://{authority}", path, mark + query


def local_path(location: str) -> str | None:
    """The local file a location names: a path as given, a file:// URL's path; None for a store's URL (no output
    of this machine can be that object)."""
    if not is_url(location):
        return str(location)
    if not str(location).lower().startswith("file://"):
        return None
    from urllib.parse import unquote, urlsplit
    return unquote(urlsplit(str(location)).path) or None


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


ANSWER_S = 20  # each request's limit in wall time, its connection and retries included
NO_ANSWER = f"no answer from the store within {ANSWER_S} s"
READ_BYTES = 4 << 20  # the most one read asks for: a store that sends 0.2 MB/s answers it in time
# The clients' own limits end a silent store's request at 21-22 s: just after ANSWER_S has marked the store as one
# that did not answer (a failure of their own first would let the next request wait again), and soon enough not to
# hold the exit long (pyarrow's S3 finalizer waits for every request). S3: 7 s to connect, 7 s without a byte,
# 3 attempts (pyarrow's 1 s, 3 s and retries took 99 s); Google Cloud Storage: 21 s of retries (15 min by default)
S3_ATTEMPT_S, S3_ATTEMPTS = 7, 3
GCS_RETRY_S = S3_ATTEMPT_S * S3_ATTEMPTS
AZURE_SCHEMES = ("abfs://", "abfss://")
_UNANSWERED: dict[str, float] = {}  # a store's scheme://authority -> when a request to it went unanswered


def _answered(root: str, call: Callable[[], T]) -> T:
    """call() on the store at `root`, given `ANSWER_S` and open to Ctrl-C; its failure as the OSError a file's
    would be. A store that left a request unanswered is not asked again for `ANSWER_S`: the next request (verify
    asks for an object's size, then opens it) would wait as long for the same silence."""
    since = _UNANSWERED.get(root)
    if since is not None and time.monotonic() - since < ANSWER_S:
        raise OSError(errno.ETIMEDOUT, NO_ANSWER)
    try:
        return within(ANSWER_S, call, "the store")
    except TimeoutError as exc:
        _UNANSWERED[root] = time.monotonic()
        raise _unreadable(exc) from None
    except Exception as exc:
        raise _unreadable(exc) from None


def _limited(store):
    """`store` with this module's limits, which a URL's query cannot set, rebuilt from its pickled options so that
    the rest of what the URL and the environment said (region, endpoint, credentials) stays."""
    import pyarrow.fs as pafs
    if isinstance(store, pafs.S3FileSystem):
        rebuild, (options,) = store.__reduce__()
        return rebuild({**options, "connect_timeout": S3_ATTEMPT_S, "request_timeout": S3_ATTEMPT_S,
                        "retry_strategy": pafs.AwsStandardS3RetryStrategy(max_attempts=S3_ATTEMPTS)})
    if isinstance(store, pafs.GcsFileSystem):
        rebuild, (options,) = store.__reduce__()
        return rebuild({**options, "retry_time_limit": timedelta(seconds=GCS_RETRY_S)})
    return store


def _without_missing_az() -> None:
    """Azure's default credentials ask the az CLI through /bin/sh, which then says `az: not found` on our stderr
    (twice) where it is not installed: there the chain keeps the credentials it could use anyway (environment,
    workload or managed identity). A user's own AZURE_TOKEN_CREDENTIALS wins."""
    if shutil.which("az") is None:
        os.environ.setdefault("AZURE_TOKEN_CREDENTIALS", "prod")


def _store(location: str):
    """(pyarrow filesystem, path inside it) of a URL, the path as written (spaces and any letters, no
    percent-encoding); it may ask the store (S3's region): call it inside `_answered`."""
    import pyarrow.fs as pafs
    root, path, query = _parts(location)
    if root.startswith(AZURE_SCHEMES):
        _without_missing_az()
    store, base = pafs.FileSystem.from_uri(root + "/" + query)  # ArrowInvalid for an unknown scheme
    return _limited(store), f"{base.rstrip('/')}/{path}".rstrip("/") if path else base


def _on_store(location: str, ask: Callable[..., T]) -> T:
    """ask(store, path) of a URL, answered within `ANSWER_S`; OSError otherwise."""
    return _answered(_parts(location)[0], lambda: ask(*_store(location)))


class _StoreFile(io.RawIOBase):
    """A store's file as a Python raw file whose failures are OSErrors, as a local file's are (zipfile seeks
    before the start of a tiny object; pyarrow says ArrowInvalid, a file says OSError, which the readers catch).
    A read asks for at most `READ_BYTES` and is answered within `ANSWER_S`; the callers read on, as from a pipe."""

    def __init__(self, native, root: str):
        self._native, self._root = native, root
        self._abandoned = False

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
        view = memoryview(buffer).cast("B")[:READ_BYTES]
        try:
            return _answered(self._root, lambda: self._native.readinto(view))
        except OSError as exc:
            self._abandoned = exc.errno in (errno.ETIMEDOUT, errno.ECANCELED)  # the read goes on without us
            raise

    def seek(self, offset: int, whence: int = 0) -> int:
        return self._call("seek", offset, whence)

    def tell(self) -> int:
        return self._call("tell")

    def close(self) -> None:
        if not self.closed and not self._abandoned:  # an abandoned read still holds the native file
            self._native.close()
        super().close()


def open_binary(location: str) -> BinaryIO:
    """The recording's bytes as a buffered, seekable binary file; OSError as `open` raises it."""
    if not is_url(location):
        return open(location, "rb")
    native = _on_store(location, lambda store, path: store.open_input_file(path))
    return io.BufferedReader(_StoreFile(native, _parts(location)[0]), buffer_size=1 << 20)


def size(location: str) -> int:
    """Bytes of the recording; OSError when it is not there."""
    if not is_url(location):
        import os
        return os.stat(location).st_size
    info = _on_store(location, lambda store, path: store.get_file_info(path))
    if info.size is None:
        raise OSError(errno.ENOENT, "no object there")
    return info.size


def listing(location: str, suffixes: tuple[str, ...]) -> list[str] | None:
    """The URLs of the objects directly under a URL that names a folder (a prefix), whose names end in one of
    `suffixes` (any case) and do not start with '.', by name; None when the URL names no folder."""
    import pyarrow.fs as pafs

    def objects(store, path: str):
        if store.get_file_info(path).type != pafs.FileType.Directory:
            return None
        return store.get_file_info(pafs.FileSelector(path, recursive=False))

    found = _on_store(location, objects)
    if found is None:
        return None
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
