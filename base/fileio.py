"""Output files, by one rule anyone can predict (docs/reliability.md, "Nothing is lost"):

- `-o FILE` never replaces an existing file unless `--force`;
- never writes onto an input of the same command, even with `--force`;
- never replaces anything but a regular file (a device, pipe, socket, folder or symbolic link stays);
- a report folder must be new, empty, or a report thermoplc wrote: its `.thermoplc-report` lists
  the files it owns, and only those are replaced;
- every output is written to a temporary file beside it and renamed into place, all outputs of a
  command together at the end (all or nothing); a new file gets the umask's mode, a replaced file
  keeps its own; SIGINT and SIGTERM remove the temporary files.
"""
from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

from thermoplc.base.errors import UserError
from thermoplc.base.locations import refuse_as_output

REPORT_MANIFEST = ".thermoplc-report"


def same_file(a: Path, b: Path) -> bool:
    """Whether two paths name the same file; when either does not exist (yet), whether both resolve alike."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return a.resolve() == b.resolve()


def check_output(path: str | Path, force: bool, inputs=()) -> None:
    """Refuse an output path the rule does not allow (module docstring), before any work is done."""
    if str(path) == "-":
        raise UserError("-o -: this command writes a file (only generate writes its block to standard output); "
                        "give a file name")
    if not str(path):
        raise UserError("-o '': an empty name; expected a file name for the output")
    refuse_as_output(str(path), "an output")
    if str(path).endswith(("/", os.sep)):
        raise UserError(f"{path}: ends in a separator, so it names a folder; expected a file name for the output")
    path = Path(path)
    for source in inputs:
        if source and same_file(path, Path(source)):
            raise UserError(f"{path}: is also an input of this command; thermoplc never writes onto its input, "
                            f"not even with --force: choose another output name")
    if not os.path.lexists(path):
        return
    mode = os.lstat(path).st_mode
    if stat.S_ISDIR(mode):
        raise UserError(f"{path}: is a folder; expected a file name for the output")
    if not stat.S_ISREG(mode):
        raise UserError(f"{path}: exists and is not a regular file (a link, device, pipe or socket); thermoplc never "
                        f"replaces one, not even with --force")
    if not force:
        raise UserError(f"{path}: exists; refusing to replace it (use --force to overwrite, or choose another name)")


def check_report_folder(folder: str | Path, names: list[str], inputs=(), recognised=None) -> list[str]:
    """The report folder must be new, empty or thermoplc's own report, and no file it would write may be
    someone else's. Returns the files of the old report that the new one does not write (to remove):
    listed in the manifest and named as a report names its files (`recognised`, by default only the
    names written now), so a hand-edited manifest cannot make thermoplc delete a file of the user's."""
    refuse_as_output(str(folder), "a report")
    folder = Path(folder)
    for source in inputs:
        if source and same_file(folder, Path(source)):
            raise UserError(f"--report {folder}: is also an input of this command")
    if not os.path.lexists(folder):
        return []
    if not stat.S_ISDIR(os.lstat(folder).st_mode):
        raise UserError(f"--report {folder}: exists and is not a folder")
    present = set(os.listdir(folder))
    if not present:
        return []
    manifest = folder / REPORT_MANIFEST
    if REPORT_MANIFEST not in present or not stat.S_ISREG(os.lstat(manifest).st_mode):
        raise UserError(f"--report {folder}: is not empty and is not a report thermoplc wrote (no {REPORT_MANIFEST}); "
                        f"give a new or empty folder")
    owned = {line.strip() for line in manifest.read_text(encoding="utf-8", errors="replace").splitlines()
             if line.strip() and "/" not in line and line.strip() not in (".", "..")}
    foreign = sorted(n for n in names if n in present and n not in owned)
    if foreign:
        raise UserError(f"--report {folder}: {', '.join(foreign)} exists and is not listed in {REPORT_MANIFEST}; "
                        f"thermoplc replaces only its own files: give a new or empty folder")
    for name in names:
        if name in present and not stat.S_ISREG(os.lstat(folder / name).st_mode):
            raise UserError(f"--report {folder}: {name} is not a regular file; thermoplc never replaces one")
    ours = recognised or (lambda name: name in names)
    return sorted(n for n in owned & present if n not in names and n != REPORT_MANIFEST and ours(n)
                  and stat.S_ISREG(os.lstat(folder / n).st_mode))


def report_manifest(names: list[str]) -> str:
    """The text of a report folder's `.thermoplc-report`: a comment line, then the names of the files it owns."""
    return "\n".join(["# files of a thermoplc report; only these are replaced when it is written again", *names]) + "\n"


def _new_file_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def write_outputs(items: list[tuple[str | Path, str | bytes]], remove: list[str | Path] = ()) -> None:
    """Write every (path, data) to a temporary file beside it, then rename them all into place and
    remove `remove`: the targets keep their old content or get the complete new one, never half,
    and a failure before the renames leaves no output changed."""
    staged: list[tuple[str, Path]] = []
    try:
        for path, data in items:
            path = Path(path)
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
            except OSError as exc:
                raise UserError(f"{path}: cannot write: {exc.strerror}; nothing written") from None
            staged.append((tmp, path))
            try:
                with os.fdopen(fd, "wb") as handle:
                    handle.write(data.encode("utf-8") if isinstance(data, str) else data)
                    handle.flush()
                    os.fsync(handle.fileno())
                mode = os.stat(path).st_mode & 0o7777 if path.is_file() else _new_file_mode()
                os.chmod(tmp, mode)
            except OSError as exc:
                raise UserError(f"{path}: cannot write: {exc.strerror}; nothing written") from None
        for tmp, path in staged:
            try:
                os.replace(tmp, path)
            except OSError as exc:
                raise UserError(f"{path}: cannot write: {exc.strerror}") from None
        staged = []
        for path in remove:
            Path(path).unlink(missing_ok=True)
    finally:
        for tmp, _ in staged:
            Path(tmp).unlink(missing_ok=True)


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Write one output all or nothing (`write_outputs` for a single file); a UserError says why it could not."""
    write_outputs([(path, data)])
