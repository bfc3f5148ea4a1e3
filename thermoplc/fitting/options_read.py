"""A fit option or column role given for a kind that does not read it is refused, never silently ignored — in
the same words from the command line and the Python API (issue 60: `settings={"bins": 4}` on mlr, and `--speed`
or `--ambient` on mlr, fitted the same model as without them). Which kind reads what is declared by the kinds
themselves (models/kind.py::Kind.reads, Kind.roles)."""
from __future__ import annotations

from thermoplc.base.errors import UserError
from thermoplc.fitting.fit import FitRequest
from thermoplc.models.kind import Kind
from thermoplc.models.kinds import kind_of, options, readers, registry


def _readers_text(names: list[str]) -> str:
    return f"--model {', '.join(names[:-1])}{' or ' if len(names) > 1 else ''}{names[-1]}"


def refuse_options_not_read(request: FitRequest, given: dict[str, str]) -> None:
    """Raise a UserError for the first option given (field -> the flag it was given as) that the request's kind
    does not read. With `--model auto`, an option counts as read when a kind that `auto` tries with these roles
    reads it: `--bins 12` reaches the Bayes candidates and no other."""
    for field, option in given.items():
        owners = readers(field)
        if not owners:  # an option of every fit
            continue
        names = [k.name for k in owners]
        if request.kind != "auto":
            if not kind_of(request.kind).reads(field):
                raise UserError(f"{option} is read by {_readers_text(names)} only; --model {request.kind} does not "
                                f"read it, leave it out")
            if why := kind_of(request.kind).conflict(request.option, field):
                raise UserError(why)
            continue
        from thermoplc.fitting.auto import tried
        if not set(names) & {k.name for k in tried(request)}:
            raise UserError(f"{option} is read by {_readers_text(names)} only, which --model auto does not try here "
                            f"({'; '.join(_why_not_tried(k, request) for k in owners)}); leave it out")


def refuse_settings_not_read(request: FitRequest) -> None:
    """The API's settings by the same rule: each option given other than its default, named by its flag."""
    declared = options()
    refuse_options_not_read(request, {field: declared[field].flag for field, _ in request.settings})


def refuse_roles_not_read(request: FitRequest, speed_read_by: str | None = None) -> None:
    """--speed or --ambient given for a kind that reads no such input (roles_not_read) is refused."""
    problem = roles_not_read(request, speed_read_by)
    if problem:
        raise UserError(problem)


def roles_not_read(request: FitRequest, speed_read_by: str | None = None) -> str | None:
    """Why --speed or --ambient is given for a kind that reads no such input (auto tries the kinds that do), or
    None; the speed may still be read by the command itself (`speed_read_by`: folds cut at standstills,
    --resample holds it)."""
    if request.kind == "auto":
        return None
    kind = kind_of(request.kind)
    for role in ("speed", "ambient"):
        if getattr(request, role) is None or role in kind.roles or (role == "speed" and speed_read_by):
            continue
        names = [k.name for k in registry().values() if role in k.roles]
        also = (" (and by --folds on one recording, which cuts it at standstills, or --resample, which holds it)"
                if role == "speed" else "")
        instead = " or name it in --temps to read it as a temperature" if role == "ambient" else ""
        return (f"--{role} is read by {_readers_text(names)} only{also}; --model {request.kind} does not read it: "
                f"leave it out{instead}")
    return None


def _why_not_tried(kind: Kind, request: FitRequest) -> str:
    if not kind.auto:
        return f"{kind.name} is no candidate of auto"
    missing = [f"--{role}" for role in kind.roles if getattr(request, role) is None]
    return f"{kind.name} needs {' and '.join(missing)}"
