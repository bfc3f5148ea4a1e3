"""`fit` options that only some kinds read (`--bins`, `--lags`, `--optimizer`, `--tool-length`, ...):
one given for a kind that does not read it is refused, not silently ignored. Which kind reads what
is declared by the kinds themselves (models/kind.py::Kind.reads). `--speed` and `--ambient` are no
such options: they say which columns of the recording hold the speed and the ambient, which
`auto` and `--folds` read too, so a kind that does not use them leaves them out."""
from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from thermoplc.fitting.fit import FitRequest
    from thermoplc.models.kind import Kind


class Given(argparse.Action):
    """A plain option that also notes that the user gave it (a default is never "given"), in
    `args.given` as (field, option) pairs."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        setattr(namespace, self.dest, values)
        namespace.given = (*getattr(namespace, "given", ()), (self.dest, max(self.option_strings, key=len)))


def refuse_options_not_read(args: argparse.Namespace, request: FitRequest) -> None:
    """Raise a UserError for the first option given that the chosen kind does not read. With
    `--model auto`, an option counts as read when a kind that `auto` tries with these roles reads it:
    `--bins 12` reaches the Bayes candidates and no other."""
    from thermoplc.base.errors import UserError
    from thermoplc.models.kinds import kind_of, readers
    for field, option in dict(args.given).items():
        owners = readers(field)
        if not owners:  # an option of every fit
            continue
        names = [k.name for k in owners]
        readers_text = f"--model {', '.join(names[:-1])}{' or ' if len(names) > 1 else ''}{names[-1]}"
        if args.model != "auto":
            if not kind_of(args.model).reads(field):
                raise UserError(f"{option} is read by {readers_text} only; --model {args.model} does not read it, "
                                f"leave it out")
            continue
        from thermoplc.fitting.auto import tried
        if not set(names) & {k.name for k in tried(request)}:
            raise UserError(f"{option} is read by {readers_text} only, which --model auto does not try here "
                            f"({'; '.join(_why_not_tried(k, request) for k in owners)}); leave it out")


def _why_not_tried(kind: Kind, request: FitRequest) -> str:
    if not kind.auto:
        return f"{kind.name} is no candidate of auto"
    missing = [f"--{role}" for role in kind.roles if getattr(request, role) is None]
    return f"{kind.name} needs {' and '.join(missing)}"
