"""A campaign: the runs (recordings) of one machine, read once, each with its attributes.

A machine is characterised over tens of runs of a few hours (hall air held or ramped, speed
programmes, cold and warm starts), often with the drift probed every N minutes, empty or held in
between. A run is one recording; the block starts at its first row, as after a power-on or a
Reset. The runs come from `--data` repeated, a folder of recordings, or a runs table (CSV, one row
per run: a `file` column, relative to the table's folder, and free attribute columns such as the hall
air setpoint, the speed programme or the date). One recording is a campaign of one run. Nothing here
joins runs into one series: the fit, the folds and the verdicts iterate over them.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.models.table import Table, read_table

RECORDING_SUFFIXES = (".csv", ".npz", ".parquet")
FILE_COLUMN = "file"
RUNS_TABLE = "runs.csv"  # in a folder given as --data: its runs table, not a run


@dataclass(frozen=True)
class Run:
    """One recording and its attributes from the runs table (empty without one)."""
    table: Table
    attributes: dict

    @property
    def name(self) -> str:
        return Path(self.table.path).name


@dataclass(frozen=True)
class Campaign:
    runs: tuple[Run, ...]
    attributes: tuple[str, ...] = ()  # the runs table's attribute columns, in its order

    @property
    def tables(self) -> list[Table]:
        return [run.table for run in self.runs]

    def groups(self, attribute: str) -> dict[str, list[int]]:
        """Run indices by their value of `attribute`, in order of first appearance."""
        if attribute not in self.attributes:
            known = ", ".join(self.attributes) if self.attributes else "none (give --runs TABLE)"
            raise UserError(f"--group-by {attribute}: not a column of the runs table; its attribute columns: {known}")
        grouped: dict[str, list[int]] = {}
        for k, run in enumerate(self.runs):
            grouped.setdefault(run.attributes[attribute], []).append(k)
        return grouped


def recording_paths(data: list[str]) -> list[str]:
    """`--data` values: files as given, a folder as the recordings in it (CSV, .npz, Parquet) by name, but
    for its runs table `runs.csv`."""
    paths = []
    for given in data:
        folder = Path(given)
        if given != "-" and folder.is_dir():
            found = sorted(str(p) for p in folder.iterdir()
                           if p.is_file() and p.suffix.lower() in RECORDING_SUFFIXES and p.name != RUNS_TABLE)
            if not found:
                raise UserError(f"{given}: a folder with no recordings in it (expected files ending in "
                                f"{', '.join(RECORDING_SUFFIXES)})")
            paths += found
        else:
            paths.append(given)
    if paths.count("-") > 1:
        raise UserError("--data -: standard input can be read once; give the other runs as files")
    return paths


def read_runs_table(path: str) -> tuple[list[str], list[dict], tuple[str, ...]]:
    """The runs table: each row's recording (relative to the table's folder) and attributes, and the
    attribute column names. Refuses a missing `file` column, an empty or repeated file, a row of another
    width, naming the line."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as handle:
            rows = list(csv.reader(handle))
    except OSError as exc:
        raise UserError(f"{path}: cannot read: {exc.strerror}") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise UserError(f"{path}: not a CSV text file ({exc})") from None
    rows = [(line, row) for line, row in enumerate(rows, start=1) if any(cell.strip() for cell in row)]
    if not rows:
        raise UserError(f"{path}: empty; expected a header with a {FILE_COLUMN!r} column and one row per run")
    header = [h.strip() for h in rows[0][1]]
    if FILE_COLUMN not in header:
        raise UserError(f"{path}:1: no {FILE_COLUMN!r} column; the header has {', '.join(header)}")
    if len(set(header)) != len(header) or not all(header):
        raise UserError(f"{path}:1: every column needs a name of its own; found {', '.join(map(repr, header))}")
    base = Path(path).parent
    files, attributes, seen = [], [], {}
    for line, row in rows[1:]:
        if len(row) != len(header):
            raise UserError(f"{path}:{line}: {len(row)} fields, expected {len(header)} as in the header")
        values = dict(zip(header, (cell.strip() for cell in row)))
        name = values.pop(FILE_COLUMN)
        if not name:
            raise UserError(f"{path}:{line}: column {FILE_COLUMN!r} is empty; expected the run's recording")
        file = str(base / name)
        if file in seen:
            raise UserError(f"{path}:{line}: {name} is listed twice (first on line {seen[file]})")
        seen[file] = line
        files.append(file)
        attributes.append(values)
    if not files:
        raise UserError(f"{path}: header only; expected one row per run")
    return files, attributes, tuple(h for h in header if h != FILE_COLUMN)


def held_to_probed(table: Table, column: str) -> Table:
    """A held probing signal (the last measurement repeated until the next) as measurements only: the
    first row and every row where the value changes; NaN between."""
    values = table.column(column)
    measured = np.r_[True, values[1:] != values[:-1]] & np.isfinite(values)
    return replace(table, columns={**table.columns, column: np.where(measured, values, np.nan)})


def read_campaign(data: list[str] | None, runs_table: str | None, time_column: str, decimal: str = "auto",
                  probed: tuple[str, ...] = (), held: bool = False, progress=None) -> Campaign:
    """The runs of `--data` (files, folders) or of a runs table; the `probed` columns may be empty between
    measurements (or, `held`, repeat the last measurement: only changes count)."""
    if (data is None) == (runs_table is None):
        raise UserError("give the runs as --data FILE|FOLDER (repeated) or as --runs TABLE, one of the two")
    if data is not None and len(data) == 1 and (Path(data[0]) / RUNS_TABLE).is_file():
        data, runs_table = None, str(Path(data[0]) / RUNS_TABLE)  # a campaign's folder: its runs table
    if runs_table is not None:
        paths, attributes, names = read_runs_table(runs_table)
    else:
        paths = recording_paths(data)
        attributes, names = [{} for _ in paths], ()
    runs = []
    for path, values in zip(paths, attributes):
        table = read_table(path, time_column, progress, decimal, sparse=probed)
        for column in probed if held else ():
            if column in table.columns:
                table = held_to_probed(table, column)
        runs.append(Run(table, values))
    return Campaign(tuple(runs), names)
