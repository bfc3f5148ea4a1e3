"""Errors a user can act on. The CLI prints them as one line and exits with status 2."""


class UserError(Exception):
    """Bad input: the message names the file, the line/column or field, and what was expected."""


class ClusterError(UserError):
    """The cluster, not the data, failed a task (lost, another environment, other bytes where a worker reads): no
    fallback may take the task's place, so a search over candidates stops instead of skipping one."""


def unreadable(path: str, exc: Exception, what: str = "") -> UserError:
    """A file that cannot be read, in our words: the path once, what it was to be, and why, without an errno or a
    Python exception's text (a file that is not UTF-8 says so)."""
    import errno
    reasons = {errno.ENOENT: "no such file", errno.EACCES: "permission denied", errno.EISDIR: "a folder, not a file",
               errno.ENOTDIR: "a part of the path is not a folder", errno.ELOOP: "a loop of symbolic links"}
    if isinstance(exc, UnicodeDecodeError):
        reason = f"not UTF-8 text (byte {exc.start})"
    else:
        reason = reasons.get(getattr(exc, "errno", None), str(getattr(exc, "strerror", None) or exc))
    return UserError(f"{path}: cannot read{f' {what}' if what else ''}: {reason}")
