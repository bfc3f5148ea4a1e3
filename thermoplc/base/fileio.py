"""Output files, by one rule anyone can predict (docs/reliability.md, "Nothing is lost"):

- `-o FILE` never replaces an existing file unless `--force`;
- never writes onto an input of the same command, even with `--force`;
- never replaces anything but a regular file (a device, pipe, socket, folder or symbolic link stays);
- no two outputs onto one file, none inside a report folder, no input inside one (`check_outputs`);
- a report folder must be new, empty, or a report thermoplc wrote: its `.thermoplc-report` lists
  the files it wrote with their sha256, and only those, still as written, are replaced or removed;
- every output is written to a temporary file beside it and renamed into place, all outputs of a
  command together at the end (all or nothing); a new file gets the umask's mode, a replaced file
  keeps its own; SIGINT and SIGTERM remove the temporary files.
"""
from __future__ import annotations

import hashlib
import os
import re
import stat
import tempfile
from pathlib import Path

from thermoplc.base.errors import UserError
from thermoplc.base.locations import is_url, local_path, refuse_as_output

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
    for source in (local_path(str(s)) for s in inputs if s):  # a file:// URL is its file
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


def _inside(path: str | Path, folder: str | Path) -> bool:
    """Whether `path` is `folder` or lies anywhere below it, symbolic links resolved."""
    path, folder = Path(path).resolve(), Path(folder).resolve()
    return path == folder or folder in path.parents


def check_outputs(outputs: dict[str, str | None], force: bool, inputs=(), report: str | None = None,
                  report_names: list[str] = (), recognised=None) -> list[str]:
    """Every output of a command by the one rule: each file by `check_output`, no two outputs onto one file,
    none inside the report folder (its files are the report's), no input inside it. `outputs` maps each
    option to its file (None: not given). Returns the report's stale files (`check_report_folder`)."""
    named = [(option, path) for option, path in outputs.items() if path is not None]
    for k, (option, path) in enumerate(named):
        check_output(path, force, inputs=inputs)
        for first, earlier in named[:k]:
            if same_file(Path(path), Path(earlier)):
                raise UserError(f"{path}: named for both {first} and {option}; give each output a file of its own")
    if report is None:
        return []
    if not str(report):
        raise UserError("--report '': an empty name; expected a folder for the report")
    if str(report) == "-":
        raise UserError("--report -: a report is a folder of files, not a stream; give a folder name")
    if is_url(str(report)):
        raise UserError(f"--report {report}: a report is written to a local folder; object-store URLs are read, never "
                        f"written; give a folder")
    for option, path in named:
        if same_file(Path(path), Path(report)):
            raise UserError(f"--report {report}: is also the {option} output; give the report a folder of its own")
        if _inside(path, report):
            raise UserError(f"{path}: is inside the --report folder {report}, whose files are the report's; give "
                            f"{option} a file outside it")
    for source in (local_path(str(s)) for s in inputs if s):
        if source and _inside(source, report) and not same_file(Path(report), Path(source)):
            raise UserError(f"--report {report}: holds {source}, an input of this command; give the report a folder "
                            f"of its own")
    return check_report_folder(report, list(report_names), inputs, recognised)


def _digest(path: Path) -> str:
    with open(path, "rb") as handle:
        return hashlib.file_digest(handle, "sha256").hexdigest()


def _owned(manifest: Path) -> dict[str, str]:
    """The files a report's manifest says thermoplc wrote, each with the sha256 it had when written; lines
    without a digest (a hand edit, an older thermoplc) own nothing."""
    owned = {}
    for line in manifest.read_text(encoding="utf-8", errors="replace").splitlines():
        name, _, digest = line.strip().rpartition(" ")
        if name and "/" not in name and name not in (".", "..") and re.fullmatch(r"[0-9a-f]{64}", digest):
            owned[name.strip()] = digest
    return owned


def _named(manifest: Path) -> set[str]:
    """Every name a manifest's lines start with, digest or not."""
    return {line.split()[0] for line in manifest.read_text(encoding="utf-8", errors="replace").splitlines()
            if line.strip() and not line.startswith("#")}


def check_report_folder(folder: str | Path, names: list[str], inputs=(), recognised=None) -> list[str]:
    """The report folder must be new, empty or thermoplc's own report, and no file it would write may be
    someone else's: a file is the report's only while the manifest lists it with the sha256 it has now, so a
    file edited, replaced or written there by anyone else is never replaced nor removed. Returns the files of
    the old report that the new one does not write (to remove): the report's own, named as a report names its
    files (`recognised`, by default only the names written now)."""
    refuse_as_output(str(folder), "a report")
    folder = Path(folder)
    for source in (local_path(str(s)) for s in inputs if s):
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
    listed = _owned(manifest)
    ours = {n for n, digest in listed.items() if n in present and stat.S_ISREG(os.lstat(folder / n).st_mode)
            and _digest(folder / n) == digest}
    for name in names:
        if name in present and name not in ours:
            why = ("is not listed in" if name not in listed and name not in _named(manifest) else
                   "is listed without its sha256 (a report of an older thermoplc, or a hand edit) in"
                   if name not in listed else "was changed since thermoplc wrote it, says")
            raise UserError(f"--report {folder}: {name} exists and {why} {REPORT_MANIFEST}; thermoplc replaces only "
                            f"its own files: give a new or empty folder")
    is_ours = recognised or (lambda name: name in names)
    return sorted(n for n in ours if n not in names and n != REPORT_MANIFEST and is_ours(n))


def report_manifest(files: list[tuple[str, str | bytes]]) -> str:
    """The text of a report folder's `.thermoplc-report`: a comment line, then each file it owns with the
    sha256 of what was written, so a file changed or put there by anyone else is never taken for the report's."""
    lines = [f"{name} {hashlib.sha256(data.encode('utf-8') if isinstance(data, str) else data).hexdigest()}"
             for name, data in files]
    return "\n".join(["# files of a thermoplc report and their sha256; only these are replaced when it is written "
                      "again", *lines]) + "\n"


def _new_file_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def write_outputs(items: list[tuple[str | Path, str | bytes]], remove: list[str | Path] = ()) -> None:
    """Write every (path, data) to a temporary file beside it, then rename them all into place and
    remove `remove`: the targets keep their old content or get the complete new one, never half,
    and a failure before the renames leaves no output changed."""
    staged: list[tuple[str, Path]] = []
    made: list[Path] = []  # folders made for the outputs: removed again when nothing is written
    try:
        for path, data in items:
            path = Path(path)
            try:
                made += reversed([p for p in (path.parent, *path.parent.parents) if not os.path.lexists(p)])
                path.parent.mkdir(parents=True, exist_ok=True)
                fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
            except (FileExistsError, NotADirectoryError):
                blocking = next((p for p in (path.parent, *path.parent.parents) if p.exists() and not p.is_dir()),
                                path.parent)
                raise UserError(f"{path}: cannot write: {blocking} is a file, not a folder; nothing written") from None
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
        staged, made = [], []
        for path in remove:
            Path(path).unlink(missing_ok=True)
    finally:
        for tmp, _ in staged:
            Path(tmp).unlink(missing_ok=True)
        for folder in reversed(made):
            try:
                folder.rmdir()
            except OSError:  # not made here after all, or not empty: it stays
                pass


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Write one output all or nothing (`write_outputs` for a single file); a UserError says why it could not."""
    write_outputs([(path, data)])
