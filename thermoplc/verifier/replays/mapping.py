"""`--inputs NAME=COLUMN`: which data column drives a block input. ST names ignore case, so a mapping is keyed
by the declared name whatever case it was given in, before anything reads it (a replay, the resampling of its
recording): `reset=R` is `Reset=R` everywhere, never a mapping half the code ignores."""
from __future__ import annotations

from thermoplc.base.errors import UserError


def known_overrides(overrides: dict | None, names, what: str) -> dict:
    """--inputs keyed by the declared names (ST names ignore case); a key no input has is an error,
    not a mapping silently ignored."""
    by_key = {name.upper(): name for name in names}
    unknown = [key for key in (overrides or {}) if key.upper() not in by_key]
    if unknown:
        raise UserError(f"--inputs maps {', '.join(unknown)}, but {what} has no such input; inputs are {', '.join(names)}")
    return {by_key[key.upper()]: column for key, column in (overrides or {}).items()}
