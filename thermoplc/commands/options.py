"""The argument types and option words the subcommands share: each value is checked when the command
line is read, and a refusal names the option (argparse adds it) and what was expected."""
from __future__ import annotations

import argparse
import datetime
import math
import re
from pathlib import Path
from typing import Callable

from thermoplc.base.values import UNIX_SECONDS, cycle_problem, number_problem
from thermoplc.commands.reads import Reads, Writes
from thermoplc.recordings.formats import described


def examples(page: str, *lines: str) -> dict:
    """add_parser keywords for a subcommand's --help: its example command lines and its docs page after the
    options (a line that continues the one before starts with spaces)."""
    shown = "\n".join(f"  {line}" for line in lines)
    return {"epilog": f"examples:\n{shown}\n\nmore: {page}", "formatter_class": argparse.RawDescriptionHelpFormatter}


FORCE_HELP = "replace an existing output file (never an input of the command, never a non-regular file)"
DECIMAL = {"choices": ("auto", ".", ","),
           "help": "decimal separator of the CSV: auto (',' when ';' separates the columns), '.' or ',' "
                   "(default: auto, or the model file's)"}


def checked(problem_of: Callable[[str], str | None]) -> Callable[[str], str]:
    """An argparse type: the text as written, refused with `problem_of`'s reason."""
    def parse(text: str) -> str:
        problem = problem_of(text)
        if problem:
            raise argparse.ArgumentTypeError(problem)
        return text
    return parse


def reading_arguments(group) -> None:
    """--decimal, --gaps and --time-format: how each command that reads recordings reads their text."""
    group.add_argument("--decimal", **DECIMAL)
    from thermoplc.recordings.reading import gaps_problem, time_format_problem
    group.add_argument("--gaps", type=checked(lambda text: gaps_problem(text)[1]), metavar="RULE",
                       help="missing cells (#N/A, empty, NaN, ---): refuse (the default), drop (the rows that have one) "
                            "or hold:DURATION (each takes its column's last value for at most DURATION: hold:30s, "
                            "hold:2min); the count is printed")
    group.add_argument("--time-format", type=checked(time_format_problem), metavar="FORM",
                       help="how the time column is written when the file cannot say: day-first or month-first "
                            "(slashed dates such as 03/01/2024), excel (Excel serial days), or a strptime pattern "
                            "('%%d/%%m/%%Y %%H:%%M:%%S'; a date and a clock time in two columns are joined with a space). "
                            "Default: ISO 8601, dotted day-first dates, seconds")


def given_reading(args: argparse.Namespace) -> dict:
    """--decimal, --gaps and --time-format as given (None: not given, so a model file's own applies)."""
    return {"decimal": args.decimal, "gaps": args.gaps, "time_format": args.time_format}


def reading_of(args: argparse.Namespace, model=None):
    """The Reading of the command line; an option not given takes the model file's (how its data were read)."""
    from thermoplc.recordings.reading import Reading, resolved
    return resolved(given_reading(args), model.reading if model is not None else Reading())


class Names(tuple):
    """Column names, and the @FILE they were read from (None when given on the command line): an input of
    the command, which no output may replace."""
    file: str | None = None


def column_list(text: str) -> Names:
    """Comma-separated column names, or @FILE written by select-sensors -o (its '#' lines are comments)."""
    file = text[1:] if text.startswith("@") else None
    if file is not None:
        try:
            text = Path(text[1:]).read_text("utf-8").strip()
        except OSError as exc:
            raise argparse.ArgumentTypeError(f"cannot read {text[1:]}: {exc.strerror}") from None
        text = ",".join(line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#"))
    names = tuple(c.strip() for c in text.split(","))
    if not any(names):
        raise argparse.ArgumentTypeError("expected comma-separated column names")
    if not all(names):
        raise argparse.ArgumentTypeError(f"an empty column name in {text!r} (two commas, or one at an end); name each "
                                         f"column once")
    found = Names(names)
    found.file = file
    return found


def named(what: str) -> Callable[[str], str]:
    """An argparse type: any text but an empty one (an empty path would read as the current folder)."""
    def parse(text: str) -> str:
        if not text:
            raise argparse.ArgumentTypeError(f"expected {what}, found an empty name")
        return text
    return parse


columns = Reads("list", column_list)  # an @FILE list is an input of the command
RECORDING = Reads("recordings", named(f"a recording ({described()}) or a folder of them"))
RUNS_TABLE = Reads("runs table", named("a runs table (CSV)"))
MODEL_FILE = Reads("file", named("a model file"))
READ_FILE = Reads("file")  # a block, a model or one recording, taken as given (the reading names a bad one)
OUTPUT = Writes()  # -o FILE: checked by base/fileio.check_outputs


def number(kind: type, low: float, high: float, what: str = "") -> Callable[[str], float]:
    """An argparse type: a finite int or float within [low, high] (the option is named by argparse)."""
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {'an integer' if kind is int else 'a number'}, found {text!r}") from None
        problem = number_problem(value, kind, low, high, what, shown=text)
        if problem:
            raise argparse.ArgumentTypeError(problem)
        return value
    return parse


def every(text: str):
    """--probe-every: a probing every N calls (a bare number) or every duration (30min, 1800s, 0.5h)."""
    from thermoplc.base.values import every_problem
    found, problem = every_problem(text)
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return found


EVERY_HELP = "N calls (a bare number) or a duration: 30min, 1800s, 0.5h"


def cycle(text: str) -> float:
    """--resample PERIOD: the block's cycle in seconds, more than 0 and at most a day, a whole number of
    milliseconds (a PLC cycle is set in ms)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, found {text!r}") from None
    problem = cycle_problem(value, shown=text)
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return round(value * 1000) / 1000


RESAMPLE = {"type": cycle, "metavar": "SECONDS",
            "help": "take raw logger data onto the block's cycle of SECONDS (temperatures linear, the speed its "
                    "last value, a probing at the call that follows it; docs/campaigns.md); the model file "
                    "records the rule and verify applies it"}
SEED = number(int, 0, 2 ** 32 - 1, "a seed")
SECONDS = number(float, -UNIX_SECONDS, UNIX_SECONDS, "seconds")  # a logger's Unix time stamps too
ROWS = number(int, 1, 10 ** 9, "a row count")
RUNS = number(int, 1, 10 ** 6, "a run count")


def value_range(text: str) -> tuple[float, float]:
    """LOW,HIGH: finite, LOW below HIGH, within +-1e6, each end 0 or a normal binary32 size."""
    try:
        low, high = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LOW,HIGH (two numbers), found {text!r}") from None
    if not (math.isfinite(low) and math.isfinite(high) and -1e6 <= low < high <= 1e6) \
            or any(0 < abs(end) < 1e-6 for end in (low, high)):
        raise argparse.ArgumentTypeError(f"expected LOW,HIGH with LOW below HIGH, finite, within +-1e6 and each 0 or "
                                         f"at least 1e-6 in size, found {text!r}")
    return low, high


def header_attribute(text: str) -> str:
    """AUTHOR, FAMILY or NAME of a block header, as STEP 7 takes it."""
    from thermoplc.base.identifiers import header_attribute_problem
    problem = header_attribute_problem(text)
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return text


def st_name(text: str) -> str:
    """A name the block source declares (an instance DB, say): an ST identifier within every dialect's limits."""
    from thermoplc.base.identifiers import identifier_problem
    problem = identifier_problem(text)
    if problem:
        raise argparse.ArgumentTypeError(f"{text!r} {problem}")
    return text


def block_version(text: str) -> tuple[int, int]:
    """X.Y, each part 0 to 15 (the range TIA and STEP 7 take)."""
    match = re.fullmatch(r"(\d{1,2})\.(\d{1,2})", text)
    if not match or not all(0 <= int(part) <= 15 for part in match.groups()):
        raise argparse.ArgumentTypeError(f"expected X.Y with each part 0 to 15, found {text!r}")
    return int(match.group(1)), int(match.group(2))


def date(text: str) -> str:
    """A calendar date written YYYY-MM-DD (fromisoformat alone also takes 20260102)."""
    try:
        datetime.date.fromisoformat(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a date YYYY-MM-DD, found {text!r}") from None
    if not re.fullmatch(r"\d{4}-\d{2}-\d{2}", text):
        raise argparse.ArgumentTypeError(f"expected a date YYYY-MM-DD, found {text!r}")
    return text


# tcp://HOST:PORT, HOST a name of dot-separated labels, an IPv4 address or a bracketed IPv6 one (tls:// would need
# a Dask TLS configuration this command does not take)
SCHEDULER = re.compile(r"tcp://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?"
                       r"(?:\.[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?)*):([0-9]{1,5})")


def scheduler_address(text: str) -> str:
    """A Dask scheduler's address as `dask scheduler` prints it: tcp://HOST:PORT."""
    found = SCHEDULER.fullmatch(text.strip())
    if not found or not 0 < int(found.group(2)) < 65536:
        raise argparse.ArgumentTypeError(f"expected a Dask scheduler's address tcp://HOST:PORT, found {text!r}")
    return text.strip()


def mapping(text: str) -> dict:
    """NAME=COLUMN[,NAME=COLUMN...], each name once (ST names ignore case)."""
    pairs: dict = {}
    for item in text.split(","):
        name, sep, column = item.partition("=")
        if not sep or not name.strip() or not column.strip():
            raise argparse.ArgumentTypeError(f"expected NAME=COLUMN[,NAME=COLUMN...], found {item!r}")
        if name.strip().upper() in {k.upper() for k in pairs}:
            raise argparse.ArgumentTypeError(f"{name.strip()!r} is mapped twice")
        pairs[name.strip()] = column.strip()
    return pairs


def _until(text: str) -> float:
    """--train-until SECONDS, with the other ways to choose the training part named when refused."""
    try:
        return SECONDS(text)
    except argparse.ArgumentTypeError as exc:
        raise argparse.ArgumentTypeError(f"{exc}; or choose the training part with --train-rows N, or judge by "
                                         f"cross-validation with --folds K") from None


def training_part(parser: argparse.ArgumentParser, required: bool, default: str = ""):
    """The training part, in the same words for every command that has one."""
    part = parser.add_mutually_exclusive_group(required=required)
    tail = f" (default: {default})" if default else ""
    part.add_argument("--train-until", type=_until, metavar="SECONDS", help=f"training part: rows with time <= SECONDS{tail}")
    part.add_argument("--train-rows", type=ROWS, metavar="N", help=f"training part: the first N rows{tail}")
    return part


def campaign_arguments(parser: argparse.ArgumentParser, each: str, table: str) -> None:
    """--data (repeated: a campaign) and --runs TABLE, in the same words for every command that takes runs;
    `each` says what a run is to this command, `table` what the runs table's columns are for."""
    parser.add_argument("--data", action="append", type=RECORDING,
                        help=f"a run's recording ({described()}) or a folder of them; repeat for a campaign of "
                             f"runs, {each}")
    parser.add_argument("--runs", metavar="TABLE", type=RUNS_TABLE,
                        help="runs table instead of --data: a CSV with a 'file' column (relative to the table)"
                             f"{table}, one row per run")
