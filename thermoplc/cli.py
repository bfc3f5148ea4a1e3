"""thermoplc: thermal-error models of machine tools, compiled into PLC blocks and proven bit for bit.

The command line is a thin layer over the library (thermoplc.api), one subcommand each; each subcommand's
--help has an example and names its docs page."""
from __future__ import annotations

import argparse
import errno
import os
import re
import signal
import sys

from thermoplc.base.version import __version__
from thermoplc.base import deadline
from thermoplc.base.errors import UserError


NUMBERS = re.compile(r"-(\d|\.\d|inf|nan|0x)", re.IGNORECASE)  # a value: -40,150, -1e-3, -inf,150 (not an option)


class _StoreOnce(argparse._StoreAction):
    """An option of one value given twice is refused: argparse would keep the last and drop the first without
    a word (`diff a b --data x.csv --data y.csv` replayed y.csv only)."""

    def __call__(self, parser, namespace, values, option_string=None):
        shown = ",".join(map(str, values)) if isinstance(values, (tuple, list)) else str(values)
        if getattr(self, "given", None) is not None:
            parser.error(f"{option_string or self.dest} given twice ({self.given} and {shown}); this option takes "
                         f"one value")
        self.given = shown
        super().__call__(parser, namespace, values, option_string)


class _Parser(argparse.ArgumentParser):
    """Command-line mistakes in one line, like every other error (the usage is one --help away)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)  # --temp is no --temps: a prefix is refused with a suggestion
        super().__init__(*args, **kwargs)
        self.register("action", None, _StoreOnce)
        self.register("action", "store", _StoreOnce)

    def error(self, message: str):
        self.exit(2, f"thermoplc: error: {message} (see {self.prog} --help)\n")

    def parse_args(self, args=None, namespace=None):
        """As argparse, but an option the command does not have is named with the one it most likely meant, before
        any other complaint (a misspelled --temps is no missing --temps)."""
        args = list(sys.argv[1:] if args is None else args)
        at = next((k for k, word in enumerate(args) if word in self._commands()), None)
        if at is not None and "--help" not in args and "-h" not in args:
            command = self._commands()[args[at]]
            words = args[at + 1:]
            words = words[:words.index("--")] if "--" in words else words  # after '--' every word is a value
            _refuse_unknown(command, [w for w in words if w.startswith("--")
                                      and w.split("=", 1)[0] not in command._option_string_actions])
        found, extras = self.parse_known_args(args, namespace)
        _refuse_unknown(self._commands().get(getattr(found, "command", None), self), extras)
        return found

    def _commands(self) -> dict:
        """The subcommands' parsers by name (none for a subcommand's own parser)."""
        return next((a.choices for a in self._actions if isinstance(a, argparse._SubParsersAction)), {})

    def parse_known_args(self, args=None, namespace=None):
        """A value that starts with '-' but is a number or a list of numbers (`--temp-range -40,150`, as --help
        prints the default) is the option's value, not another option: argparse only knows lone numbers."""
        args = list(sys.argv[1:] if args is None else args)
        glued, k = [], 0
        while k < len(args):
            action = self._option_string_actions.get(args[k])
            if action is not None and action.nargs is None and k + 1 < len(args) and NUMBERS.match(args[k + 1]):
                glued.append(f"{args[k]}={args[k + 1]}")
                k += 2
                continue
            glued.append(args[k])
            k += 1
        return super().parse_known_args(glued, namespace)


# options users reach for that a command spells otherwise: (the word typed, the option the command has)
RELATED = (("--temps", "--candidates"), ("--candidates", "--temps"), ("--input", "--data"), ("--csv", "--data"),
           ("--output", "-o"), ("--out", "-o"), ("--probe-minutes", "--probe-every"), ("--kind", "--model"))


def _refuse_unknown(parser: argparse.ArgumentParser, words: list[str]) -> None:
    """The words `parser` has no use for, refused in one line with the options they most likely meant."""
    if words:
        hints = "; ".join(h for h in (_suggestion(w, parser) for w in words if w.startswith("-")) if h)
        parser.error(f"unrecognized arguments: {' '.join(words)}" + (f" ({hints})" if hints else ""))


def _suggestion(word: str, parser: argparse.ArgumentParser) -> str:
    """'did you mean --X?' for an option `word` the command lacks: a related spelling, else the closest."""
    import difflib
    name = word.split("=", 1)[0]
    options = [o for o in parser._option_string_actions if o.startswith("--")]
    related = [option for typed, option in RELATED if typed == name and option in parser._option_string_actions]
    close = related or difflib.get_close_matches(name, options, n=1, cutoff=0.6)
    return f"{name}: did you mean {close[0]}?" if close else ""


def build_parser() -> argparse.ArgumentParser:
    # the commands (and the choices they take from the packages) are imported here, inside main's
    # handling of Ctrl-C; one module per subcommand in thermoplc.commands, in the order of --help
    from thermoplc.commands import demo, diagnose, diff, fit, generate, select_sensors, testbench, twin, verify
    from thermoplc.commands.reads import declare
    parser = _Parser(prog="thermoplc", description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--version", action="version", version=f"thermoplc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for command in (demo, twin, fit, select_sensors, diagnose, generate, diff, verify, testbench):
        command.add_parser(sub)
    for each in sub.choices.values():
        declare(each)  # the options whose files the command reads: no output of it may replace one
    return parser


class Terminated(BaseException):
    """SIGTERM, raised where the program is so that temporary files are removed on the way out."""


def _terminate(signum, frame):
    deadline.interrupted()
    raise Terminated()


def _interrupt(signum, frame):
    """Ctrl-C: KeyboardInterrupt here, and every wait for a store or a scheduler ends, on any thread
    (base/deadline.py)."""
    deadline.interrupted()
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    signal.signal(signal.SIGTERM, _terminate)
    # `kill -INT` stops a run started in the background of a script too (such a shell starts it with SIGINT
    # ignored): an interrupt is always the clean stop, never a fit that goes on for hours
    signal.signal(signal.SIGINT, _interrupt)
    try:
        return _run(argv)
    finally:
        try:
            if sys.stdout is not None:  # None: started with stdout closed (`>&-`), nothing was printed
                sys.stdout.flush()
        except OSError:  # stdout is a full disk or a closed pipe: nothing more can be said there
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


def run() -> None:
    """The `thermoplc` program: `main`, then the exit status. An interrupt ends with 130 by `os._exit`: CPython
    remembers a Ctrl-C that passed through code run by exec() (a dataclass being built while a module loads)
    even when `main` handled it, and would kill the process with SIGINT on the way out. A termination (143) too:
    Python's exit would wait for a store's request abandoned in native code (pyarrow's S3 finalizer)."""
    code = main()
    # the answer is out: a Ctrl-C while Python winds down (pyarrow's S3 finalizer waits for a request abandoned at
    # its limit, in native code) ends the process at once, not in a traceback from an atexit callback
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    if code in (130, 143):
        for stream in (sys.stdout, sys.stderr):
            try:
                if stream is not None:
                    stream.flush()
            except OSError:
                pass
        os._exit(code)
    sys.exit(code)


def _named_inputs(args) -> str:
    """The files a command read, for a message that cannot say which one was at fault."""
    for keys in (("block",), ("old", "new"), ("model",), ("manifest",)):  # the ST source first: it is what nests
        names = [getattr(args, key, None) for key in keys]
        if all(isinstance(n, str) for n in names):
            return ", ".join(names)
    return "an input"


def _run(argv: list[str] | None) -> int:
    args = None
    try:
        args = build_parser().parse_args(argv)
        return args.func(args)
    except UserError as exc:
        print(f"thermoplc: error: {exc}", file=sys.stderr)
        return 2
    except RecursionError:  # an expression or statement nesting deeper than Python's stack (thousands of levels)
        print(f"thermoplc: error: {_named_inputs(args)}: expressions or statements nested too deeply to read "
              f"(thousands of levels); nothing written", file=sys.stderr)
        return 2
    except MemoryError:
        print("thermoplc: error: an input needs more memory than this machine has (a huge array or table?); "
              "nothing written", file=sys.stderr)
        return 2
    except BrokenPipeError:  # the reader left (`| head`): stop quietly with the shell's SIGPIPE status
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except KeyboardInterrupt:
        print("thermoplc: interrupted; nothing half-written left behind", file=sys.stderr)
        return 130
    except Terminated:
        print("thermoplc: terminated; nothing half-written left behind", file=sys.stderr)
        return 143
    except OSError as exc:  # writing the answer failed: stdout on a full disk, say
        if exc.errno == errno.EPIPE:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 141
        print(f"thermoplc: error: {exc.filename or 'standard output'}: {exc.strerror or exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
