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
import io
import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from thermoplc.base.errors import ClusterError, UserError, unreadable
from thermoplc.base.locations import is_url, listing, name as name_of, open_binary
from thermoplc.recordings.formats import suffixes
from thermoplc.recordings.reading import Reading
from thermoplc.recordings.resample import Resampling, resample
from thermoplc.recordings.table import Table, read_table

FILE_COLUMN = "file"
RUNS_TABLE = "runs.csv"  # in a folder given as --data: its runs table, not a run
MIN_CALLS = 10  # a run resampled onto fewer calls is too short for any fit or diagnosis


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

    @property
    def labels(self) -> list[str]:
        """Each run's name in tables (run_labels)."""
        return run_labels([run.table.path for run in self.runs])

    def groups(self, attribute: str) -> dict[str, list[int]]:
        """Run indices by their value of `attribute`, in order of first appearance."""
        if attribute not in self.attributes:
            known = ", ".join(self.attributes) if self.attributes else "none (give --runs TABLE)"
            raise UserError(f"--group-by {attribute}: not a column of the runs table; its attribute columns: {known}")
        grouped: dict[str, list[int]] = {}
        for k, run in enumerate(self.runs):
            if not run.attributes[attribute]:
                raise UserError(f"--group-by {attribute}: run {self.labels[k]} has no value in that column; give "
                                f"every run a group")
            grouped.setdefault(run.attributes[attribute], []).append(k)
        return grouped


@dataclass(frozen=True)
class RunList:
    """Where a campaign's runs are, before any is read: each recording, its attributes, and the runs
    table's name and line of each (empty without a table), so a run that cannot be read is named by its line."""
    paths: tuple[str, ...]
    attributes: tuple[dict, ...]
    names: tuple[str, ...] = ()
    table: str | None = None
    lines: tuple[int, ...] = ()

    def where(self, k: int) -> str:
        """The runs table's line of run k, as a message's prefix ('' without a table)."""
        return f"{self.table}:{self.lines[k]}: " if self.table else ""


def recording_paths(data: list[str]) -> list[str]:
    """`--data` values: files as given, a folder as the recordings in it (CSV and each format of recordings/formats/) by name, but
    for its runs table `runs.csv` and hidden files (a '.' first: editors' and other systems' leftovers)."""
    paths = []
    for given in data:
        folder = Path(given)
        if is_url(given):
            paths += _recordings_at(given)
        elif given != "-" and folder.is_dir():
            found = sorted(str(p) for p in folder.iterdir()
                           if p.name.lower().endswith(suffixes()) and p.name != RUNS_TABLE
                           and not p.name.startswith(".") and _recording_file(p))
            if not found:
                raise UserError(f"{given}: a folder with no recordings in it (expected files ending in "
                                f"{', '.join(suffixes())})")
            paths += found
        else:
            paths.append(given)
    if paths.count("-") > 1:
        raise UserError("--data -: standard input can be read once; give the other runs as files")
    return paths


def _recording_file(path: Path) -> bool:
    """Whether a folder's entry named like a recording is one: a file, or a link to one; a link to nothing is
    refused (a run silently missing would change the campaign), a folder named so is not a recording."""
    if path.is_symlink() and not path.exists():
        raise UserError(f"{path}: a symbolic link to {os.readlink(path)}, which does not exist; this run cannot be "
                        f"read (remove the link or restore its file)")
    return path.is_file()


def _recordings_at(url: str) -> list[str]:
    """An object-store URL as its recordings: the object itself, or the recordings under a prefix, by name."""
    try:
        found = listing(url, suffixes())
    except OSError as exc:
        raise unreadable(url, exc) from None
    if found is None:
        return [url]
    found = [each for each in found if name_of(each) != RUNS_TABLE]
    if not found:
        raise UserError(f"{url}: a folder with no recordings in it (expected objects ending in "
                        f"{', '.join(suffixes())})")
    return found


def _rows(path: str) -> list[tuple[int, list[str]]]:
    """The runs table's rows with their line numbers; blank lines skipped, ',' or ';' between the fields."""
    if path == "-":
        raise UserError("--runs -: a runs table is a file (its runs are named relative to its folder)")
    if Path(path).is_dir():
        raise UserError(f"--runs {path}: a folder; give its runs table (--runs {Path(path) / RUNS_TABLE}) or the "
                        f"folder as --data {path}")
    try:
        with open_binary(path) as handle:
            text = handle.read().decode("utf-8-sig")
        first = text.splitlines()[0] if text.strip() else ""
        delimiter = ";" if ";" in first and "," not in first else ","
        rows = list(csv.reader(io.StringIO(text), delimiter=delimiter))
    except OSError as exc:
        raise unreadable(path, exc) from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise UserError(f"{path}: not a CSV text file ({exc})") from None
    return [(line, row) for line, row in enumerate(rows, start=1) if row]


def read_runs_table(path: str) -> RunList:
    """The runs table: each row's recording (relative to the table's folder) and attributes. Refuses a
    missing `file` column, an empty or repeated file, a row of another width, naming the line."""
    rows = _rows(path)
    if not rows:
        raise UserError(f"{path}: empty; expected a header with a {FILE_COLUMN!r} column and one row per run")
    header = [h.strip() for h in rows[0][1]]
    if FILE_COLUMN not in header:
        raise UserError(f"{path}:1: no {FILE_COLUMN!r} column; the header has {', '.join(header)}")
    if len(set(header)) != len(header) or not all(header):
        raise UserError(f"{path}:1: every column needs a name of its own; found {', '.join(map(repr, header))}")
    base = path.rsplit("/", 1)[0] if is_url(path) else Path(path).parent
    files, attributes, lines, seen = [], [], [], {}
    for line, row in rows[1:]:
        if len(row) != len(header):
            raise UserError(f"{path}:{line}: {len(row)} fields, expected {len(header)} as in the header")
        values = dict(zip(header, (cell.strip() for cell in row)))
        name = values.pop(FILE_COLUMN)
        if not name:
            raise UserError(f"{path}:{line}: column {FILE_COLUMN!r} is empty; expected the run's recording")
        if "\0" in name:
            raise UserError(f"{path}:{line}: column {FILE_COLUMN!r}: a NUL character in {name!r}; no file is named so")
        if is_url(name) or Path(name).is_absolute():  # read where it is
            file = name
        else:
            file = f"{base}/{name}" if is_url(path) else str(base / name)
        if file in seen:
            raise UserError(f"{path}:{line}: {name} is listed twice (first on line {seen[file]})")
        seen[file] = line
        files.append(file)
        attributes.append(values)
        lines.append(line)
    if not files:
        raise UserError(f"{path}: header only; expected one row per run")
    return RunList(tuple(files), tuple(attributes), tuple(h for h in header if h != FILE_COLUMN), path, tuple(lines))


def _runs_table_in(folder: str) -> str | None:
    """The runs table of a folder (or of an object store's prefix), None when it has none."""
    if is_url(folder):
        try:
            found = listing(folder, (RUNS_TABLE,))
        except OSError:
            return None  # the reading of the runs says why
        return next((each for each in found or [] if name_of(each) == RUNS_TABLE), None)
    return str(Path(folder) / RUNS_TABLE) if (Path(folder) / RUNS_TABLE).is_file() else None


def run_list(data: list[str] | None, runs_table: str | None) -> RunList:
    """The runs `--data` (files, folders; a lone folder with a runs.csv is read through it) or `--runs` names."""
    if (data is None) == (runs_table is None):
        raise UserError("give the runs as --data FILE|FOLDER (repeated) or as --runs TABLE, one of the two")
    if data is not None and len(data) == 1 and data[0] != "-":  # a campaign's folder: its runs table says what
        runs_table = _runs_table_in(data[0])  # the runs are
    if runs_table is not None:
        return read_runs_table(runs_table)
    paths = recording_paths(data)
    return RunList(tuple(paths), tuple({} for _ in paths))


def held_to_probed(table: Table, column: str) -> Table:
    """A held probing signal (the last measurement repeated until the next) as measurements only: the
    first value and every one that differs from the last value before it (cells without a value between
    do not make the same value a new measurement); NaN between."""
    values = table.column(column)
    finite = np.isfinite(values)
    last = np.where(finite, np.arange(len(values)), -1)
    np.maximum.accumulate(last, out=last)  # index of the latest finite value at or before each row
    before = np.r_[-1, last[:-1]]
    previous = np.where(before >= 0, values[np.maximum(before, 0)], np.nan)
    measured = finite & ((before < 0) | (values != previous))
    return replace(table, columns={**table.columns, column: np.where(measured, values, np.nan)})


def read_campaign(runs: RunList, time_column: str, reading: Reading = Reading(), probed: tuple[str, ...] = (),
                  held: bool = False, progress=None, resampling: Resampling | None = None) -> Campaign:
    """Every run read once; the `probed` columns may be empty between measurements (or, `held`, repeat the
    last measurement: only changes count); with `resampling` each run is taken onto the block's cycle first
    (recordings/resample.py). A run that cannot be read is named by its runs table's line."""
    read = []
    for k, (path, values) in enumerate(zip(runs.paths, runs.attributes)):
        try:
            table = onto_calls(read_table(path, time_column, progress, reading, sparse=probed), time_column,
                               resampling, probed, held)
        except UserError as exc:
            relative = (f" (a runs table names its files relative to its own folder, "
                        f"{Path(runs.table).parent}/)" if runs.table and not is_url(runs.table)
                        and not is_url(path) and not Path(path).exists() else "")
            raise UserError(f"{runs.where(k)}{exc}{relative}") from None
        read.append(Run(table, values))
    return Campaign(tuple(read), runs.names)


def onto_calls(table: Table, time_column: str, resampling: Resampling | None = None, probed: tuple[str, ...] = (),
               held: bool = False) -> Table:
    """A run as read becomes the block's calls: with `resampling` taken onto the block's cycle
    (recordings/resample.py); a `held` probed column as its measurements only (held_to_probed)."""
    if resampling is not None:
        raw_rows, table = table.rows, resample(table, time_column, resampling, tuple(probed), held)
        if table.rows < MIN_CALLS:
            raise UserError(f"{table.path}: --resample {resampling.period_s:g} takes its {raw_rows} rows onto "
                            f"{table.rows} calls; at least {MIN_CALLS} are needed: give a shorter cycle")
    for column in probed if held else ():
        if column in table.columns:
            table = held_to_probed(table, column)
    return table


def run_labels(paths: list[str]) -> list[str]:
    """Each run's name in tables: its file name, or the path as given where two runs share a file name."""
    names = [Path(p).name for p in paths]
    return [name if names.count(name) == 1 else path for name, path in zip(names, paths)]


@dataclass(frozen=True, eq=False)
class CampaignSource:
    """Where a campaign's runs are, how they were read and the bytes each had: what a task on another machine
    gets instead of the data (base/cluster.py), read there by the same rules, refused there if it differs."""
    runs: RunList
    folder: str  # the reader's working folder: relative paths are taken from it
    time_column: str
    reading: Reading
    probed: tuple[str, ...]
    held: bool
    sha256: tuple[str, ...]
    resampling: Resampling | None = None

    @property
    def key(self) -> tuple:
        """What the tables read from this source depend on (a task reads no run's attributes: the client groups)."""
        return (self.runs.paths, self.folder, self.time_column, self.reading, self.probed, self.held, self.sha256,
                self.resampling)

    def read(self) -> Campaign:
        """The campaign again, each table under the path it was given; the last one read is kept (a worker
        runs many tasks of one campaign)."""
        key = self.key
        if _LAST_READ and _LAST_READ[0] == key:
            return _LAST_READ[1]
        where = replace(self.runs, paths=tuple(p if is_url(p) else str(Path(self.folder) / p) for p in self.runs.paths))
        found = read_campaign(where, self.time_column, self.reading, self.probed, self.held, resampling=self.resampling)
        runs = []
        for run, given, digest in zip(found.runs, self.runs.paths, self.sha256):
            if run.table.sha256 != digest:
                raise ClusterError(f"{run.table.path}: other bytes here (sha256 {run.table.sha256[:12]}...) than "
                                   f"where the command was given them ({digest[:12]}...); every worker must read the "
                                   f"same files")
            runs.append(replace(run, table=replace(run.table, path=given)))
        campaign = Campaign(tuple(runs), found.attributes)
        _LAST_READ[:] = [key, campaign]
        return campaign


_LAST_READ: list = []


def source_of(campaign: Campaign, runs: RunList, time_column: str, reading: Reading = Reading(),
              probed: tuple[str, ...] = (), held: bool = False, resampling: Resampling | None = None) -> CampaignSource:
    """How `campaign` was read from `runs` (read_campaign's arguments), for a task that reads it elsewhere."""
    if "-" in runs.paths:
        raise UserError("--data -: a run read from standard input cannot be read again by a cluster's workers; "
                        "give it as a file")
    return CampaignSource(runs, str(Path.cwd()), time_column, reading, tuple(probed), held,
                          tuple(t.sha256 for t in campaign.tables), resampling)
