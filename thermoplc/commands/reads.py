"""Every file a command reads, from its options, so that no output of the command replaces one (issue 60).

An option whose value the command reads is declared by its argparse type, `Reads`: a recording or folder of
runs, a runs table, a model or block file, a manifest, or a list of names that may be an @FILE. `declare`
notes a parser's reading options when the command line is built, and `files_read` expands them into the
files behind them — a folder's recordings and its runs.csv, a runs table and the runs it names, a manifest
and every file of its pairs, the @FILE a list was read from — the one list every command checks its outputs
(`-o`, `--json`, `--outputs`, `--report`) against (base/fileio.check_outputs). tests/test_reads.py walks the
parsers and fails on an option that names a file and is neither read nor written by this rule."""
from __future__ import annotations

import argparse
from typing import Callable

from thermoplc.base.locations import local_path

KINDS = ("recordings", "runs table", "file", "list", "manifest")
STDIN = "/dev/stdin"  # `--data -`: standard input, which a shell may have opened on a file an output names


class Reads:
    """An argparse type for an option whose value names what the command reads; `kind` says how to find the
    files behind it (KINDS), `parse` checks the text as the option's own type did."""

    def __init__(self, kind: str, parse: Callable[[str], object] = str):
        if kind not in KINDS:
            raise ValueError(f"unknown kind of input {kind!r}")
        self.kind, self.parse = kind, parse

    def __call__(self, text: str):
        return self.parse(text)


class Writes:
    """An argparse type for an option whose value names what the command writes (a file or a report folder)."""

    def __init__(self, parse: Callable[[str], object] = str):
        self.parse = parse

    def __call__(self, text: str):
        return self.parse(text)


def declare(parser: argparse.ArgumentParser) -> None:
    """Note the parser's reading options on the namespace it fills (`args.reads`: (dest, kind) pairs)."""
    parser.set_defaults(reads=tuple((a.dest, a.type.kind) for a in parser._actions if isinstance(a.type, Reads)))


def files_read(args: argparse.Namespace) -> list[str]:
    """Every local file the command reads, by its declared reading options: a file:// URL as its path, standard
    input as /dev/stdin (the file a shell redirected it from); an object store's URL is no file an output could
    replace."""
    kinds = dict(getattr(args, "reads", ()))
    found: list[str] = []
    for dest, kind in kinds.items():
        value = getattr(args, dest, None)
        if value is None:
            continue
        if kind == "file":
            found.append(value)
        elif kind == "list":  # an @FILE named '-' is that file, not standard input
            found.append("./-" if getattr(value, "file", None) == "-" else getattr(value, "file", None))
        elif kind == "manifest":
            found += _manifest_files(args, value)
    campaign = [dest for dest, kind in kinds.items() if kind in ("recordings", "runs table")]
    if any(getattr(args, dest, None) for dest in campaign):
        found += _campaign_files(args, kinds)
    local = [STDIN if f == "-" else local_path(str(f)) for f in found if f]
    return [f for f in dict.fromkeys(local) if f]


def _campaign_files(args: argparse.Namespace, kinds: dict[str, str]) -> list[str]:
    """The runs of --data (files, folders; a folder's runs.csv) or of --runs, and the table itself."""
    from thermoplc.base.errors import UserError
    from thermoplc.recordings.campaign import run_list
    data = next((getattr(args, d) for d, k in kinds.items() if k == "recordings"), None)
    table = next((getattr(args, d) for d, k in kinds.items() if k == "runs table"), None)
    if data is not None and table is not None:
        return [*data, table]  # refused by the command in its own words; nothing is written
    try:
        runs = run_list(data, table)
    except UserError:
        return [*(data or []), *([table] if table else [])]  # the command says what is wrong
    return [*runs.paths, *([runs.table] if runs.table else [])]


def _manifest_files(args: argparse.Namespace, manifest: str) -> list[str]:
    """The manifest and every block, recording and model file its pairs name."""
    from thermoplc.base.errors import UserError
    from thermoplc.verifier.fleets.fleet import read_manifest
    try:
        pairs = read_manifest(manifest)
    except UserError:
        return [manifest]  # the command says what is wrong
    return [manifest, *(f for p in pairs for f in (p.block, p.data, p.model))]
