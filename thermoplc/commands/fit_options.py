"""`fit` options that only some kinds read (`--bins`, `--lags`, `--optimizer`, `--tool-length`, ...):
one given for a kind that does not read it is refused, not silently ignored. Which kind reads what
is declared by the kinds themselves (models/kind.py::Kind.reads). `--speed` and `--ambient` say which
columns hold the speed and the ambient: refused too where neither the kind nor the command reads them
(auto tries the kinds that do, --folds on one recording cuts at standstills, --resample holds the speed)."""
from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from thermoplc.fitting.fit import FitRequest


class Given(argparse.Action):
    """A plain option that also notes that the user gave it (a default is never "given"), in
    `args.given` as (field, option) pairs."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        setattr(namespace, self.dest, values)
        namespace.given = (*getattr(namespace, "given", ()), (self.dest, max(self.option_strings, key=len)))


def refuse_options_not_read(args: argparse.Namespace, request: FitRequest) -> None:
    """Raise a UserError for the first option given that the chosen kind does not read (fitting/options_read.py:
    the API's words too), before any file is read."""
    from thermoplc.fitting.options_read import refuse_options_not_read as refuse
    refuse(request, dict(args.given))


def refuse_columns_not_read(args: argparse.Namespace, request: FitRequest, tables: list) -> None:
    """--speed or --ambient where nothing reads them: not the kind, nor --folds on one recording (it cuts at
    standstills), nor --resample (it holds the speed at its last value). Asked once the runs are read and their
    sample period is known, so that raw logger data hear "give --resample" first, not "leave --speed out"."""
    from thermoplc.base.errors import UserError
    from thermoplc.fitting.fit import common_sample_period
    from thermoplc.fitting.options_read import roles_not_read
    problem = roles_not_read(request, "--resample" if args.resample else
                             "--folds" if args.folds and len(tables) == 1 else None)
    if problem is None:
        return
    for table in tables:  # a typo is named first: no such column
        for column in (request.speed, request.ambient):
            if column is not None:
                table.column(column)
    if not args.resample:
        common_sample_period(tables, args.time)
    raise UserError(problem)
