"""A private cache of the fast engine's compiled blocks, so a process does not pay the C compiler again.

A library loaded from disk runs its code in the verifier, so a planted one must never be loaded.
The cache lives in the user's own folder (`$THERMOPLC_CACHE_DIR`, else `$XDG_CACHE_HOME/thermoplc/native`,
else `~/.cache/thermoplc/native`) and is used only when nobody else could have written there:
- the folder is a real folder, owned by this user, with no access for group or others (created so,
  0700); every folder above it, taken where it really is (symlinks on the way resolved first, before
  anything is created), is owned by this user or root and writable by nobody else unless sticky (a
  sticky /tmp lets nobody rename another's entries), as ssh's StrictModes asks;
- a library is a regular file owned by this user and writable by nobody else, checked through a descriptor
  opened without following a symlink, then loaded by its own name (the dynamic loader knows a library by
  its name: loading two blocks through /proc/self/fd/N would give the first block twice); between the two
  only this user could swap it, in a folder nobody else can enter;
- its name is the sha256 of the C text, the compiler flags and the compiler (path, size, modification
  time), so another block, flag or compiler never meets it; it is written under a fresh name and renamed
  into place, so a reader never sees half a file;
- it ends in a record written with it: its size and the sha256 of its name's key and its bytes. Before the
  loader sees a library, the bytes read through that same descriptor must match the record: a library cut
  short (the loader maps it whole and the process dies of SIGBUS on the missing page), emptied, overwritten,
  copied in from another entry or written by an older thermoplc (no record) is removed and compiled again.
  The record rides in the file itself (the loader maps only what the ELF's headers name, never bytes
  after them) rather than beside it, so one rename writes both and two processes storing the same block cannot pair one's library
  with the other's record. Hashing through the descriptor and then loading by name is safe for the reason
  the ownership check is: only this user can swap the file in between, and another thermoplc doing so
  puts a whole, recorded library of the same block there. A loaded library must also have the functions
  the engine calls, or it is dropped and the engine compiles afresh in a folder of its own (a new name:
  the loader would hand back the library it already holds under the old one).
Anything else (another system than Linux, a folder shared or not ours, `THERMOPLC_NATIVE_CACHE=off`) and
the engine compiles in a fresh private folder as before. The cache only saves time: a library found
here was built from the same text by the same compiler.
"""
from __future__ import annotations

import ctypes
import hashlib
import os
import stat
import sys
import tempfile
from pathlib import Path

OFF = ("0", "off", "no", "false")
MARK = b"\0thermoplc-native-cache-1\0"  # opens the record at the end of a cached library
RECORD_SIZE = len(MARK) + 8 + 32  # the mark, the library's size (8 bytes), the sha256


def folder() -> Path | None:
    """The cache folder (its real path, no symlink left in it), created private when missing; None when it
    must not be used."""
    if not sys.platform.startswith("linux") or os.environ.get("THERMOPLC_NATIVE_CACHE", "").lower() in OFF:
        return None
    wanted = _wanted()
    if wanted is None:
        return None
    try:
        existing = wanted
        while not os.path.lexists(existing) and existing != existing.parent:
            existing = existing.parent
        real = Path(os.path.realpath(existing))  # every folder above is judged where it really is
        if not _safe_ancestors(real / "x"):  # before anything is created in it
            return None
        path = real / wanted.relative_to(existing)
        _make_private(path)
        return path if _private(path) and _safe_ancestors(path) else None
    except (OSError, ValueError):
        return None


def _wanted() -> Path | None:
    """Where the cache should be: $THERMOPLC_CACHE_DIR, else the XDG cache folder (an absolute
    $XDG_CACHE_HOME, as the XDG rules say, else ~/.cache); None without a home to put it in."""
    given = os.environ.get("THERMOPLC_CACHE_DIR")
    if given:
        return Path(given).absolute()
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    try:
        base = Path(xdg) if os.path.isabs(xdg) else Path.home() / ".cache"
    except RuntimeError:  # no HOME and no passwd entry (a container's unknown uid): no cache
        return None
    return base / "thermoplc" / "native"


def _make_private(path: Path) -> None:
    missing = []
    while not os.path.lexists(path) and path != path.parent:
        missing.append(path)
        path = path.parent
    for part in reversed(missing):
        part.mkdir(mode=0o700)


def _private(path: Path) -> bool:
    info = os.lstat(path)
    return stat.S_ISDIR(info.st_mode) and info.st_uid == os.geteuid() and info.st_mode & 0o077 == 0


def _safe_ancestors(path: Path) -> bool:
    """Every folder above `path` is this user's or root's and writable by nobody else unless sticky; and is no
    symlink (the path is a real path: one that became a link since is refused)."""
    for parent in path.parents:
        info = os.lstat(parent)
        if stat.S_ISLNK(info.st_mode) or info.st_uid not in (0, os.geteuid()):
            return False
        if info.st_mode & 0o022 and not info.st_mode & stat.S_ISVTX:
            return False
    return True


def load(key: str, symbols: tuple[str, ...]) -> ctypes.CDLL | None:
    """The cached library of this key, checked, with every one of `symbols`, or None. An entry of ours that
    fails a check is removed, so the caller's fresh build takes its place."""
    where = folder()
    if where is None:
        return None
    path = where / f"{key}.so"
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError:
        return None
    try:
        if not _ours(os.fstat(fd)):
            return None  # not an entry of ours: left alone, the next store replaces the name
        library = _intact_library(path, key, _read(fd), symbols)
    except OSError:
        library = None
    finally:
        os.close(fd)
    if library is None:
        _remove(path)
    return library


def _ours(info: os.stat_result) -> bool:
    """A regular file of this user's that nobody else can write."""
    return stat.S_ISREG(info.st_mode) and info.st_uid == os.geteuid() and not info.st_mode & 0o022


def _read(fd: int) -> bytes:
    with os.fdopen(fd, "rb", closefd=False) as entry:
        return entry.read()


def _intact_library(path: Path, key: str, data: bytes, symbols: tuple[str, ...]) -> ctypes.CDLL | None:
    """The library at `path` loaded when `data` (its bytes) match their record, and it has `symbols`."""
    if data[-RECORD_SIZE:] != _record(key, data[:-RECORD_SIZE]):
        return None
    library = ctypes.CDLL(str(path))
    return library if all(hasattr(library, name) for name in symbols) else None


def _record(key: str, library: bytes) -> bytes:
    """What follows the library in its cache entry: the mark, its size and the sha256 of the key and its bytes."""
    return MARK + len(library).to_bytes(8, "little") + hashlib.sha256(key.encode() + b"\0" + library).digest()


def _remove(path: Path) -> None:
    """Best effort: a file that cannot be removed is replaced by the next store, or checked again next time."""
    try:
        path.unlink()
    except OSError:
        pass


def store(key: str, built: Path) -> None:
    """Keep a copy of `built` under `key`, its record after it; a cache that cannot be written is left alone."""
    where = folder()
    if where is None:
        return
    try:
        fd, name = tempfile.mkstemp(dir=where, prefix=".building-", suffix=".so")
    except OSError:
        return
    try:
        with os.fdopen(fd, "wb") as out:
            library = built.read_bytes()
            out.write(library + _record(key, library))
            out.flush()
            os.fsync(out.fileno())  # a crash leaves the old name or the whole new file, never half of it
        os.chmod(name, 0o700)
        os.replace(name, where / f"{key}.so")
    except OSError:
        Path(name).unlink(missing_ok=True)
