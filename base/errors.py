"""Errors a user can act on. The CLI prints them as one line and exits with status 2."""


class UserError(Exception):
    """Bad input: the message names the file, the line/column or field, and what was expected."""
