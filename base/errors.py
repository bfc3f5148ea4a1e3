"""Errors a user can act on. The CLI prints them as one line and exits with status 2."""


class UserError(Exception):
    """Bad input: the message names the file, the line/column or field, and what was expected."""


class ClusterError(UserError):
    """The cluster, not the data, failed a task (lost, another environment, other bytes where a worker reads): no
    fallback may take the task's place, so a search over candidates stops instead of skipping one."""
