"""Output files: written atomically, and never over a file thermoplc did not write unless forced."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

from thermoplc.errors import UserError

# What marks a file as thermoplc's own: blocks, model files, findings and reports name the tool in
# their first bytes; twin recordings start with the twin's header; a sensor list is one line of names.
OWN_MARKERS = (b"thermoplc", b"time_s,n_rpm,v_feed_mm_min,")
HEAD_BYTES = 4096


def written_by_us(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            head = f.read(HEAD_BYTES)
    except OSError:
        return False
    return any(marker in head for marker in OWN_MARKERS)


def check_overwrite(path: str | Path, force: bool, own=written_by_us) -> None:
    """Refuse to replace an existing file that thermoplc did not write, unless --force."""
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{path}: is a folder; expected a file name for the output")
    if path.exists() and not force and not own(path):
        raise UserError(f"{path}: exists and was not written by thermoplc; refusing to replace it "
                        f"(use --force to overwrite, or choose another name)")


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Write to a temp file beside the target and rename: the target keeps its old content or gets
    the complete new one, never half."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        payload = data.encode("utf-8") if isinstance(data, str) else data
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise UserError(f"{path}: cannot write: {exc.strerror}") from None
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(payload)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        os.unlink(tmp)
        raise UserError(f"{path}: cannot write: {exc.strerror}") from None
    except BaseException:
        os.unlink(tmp)
        raise
