"""Every bad input a user can give, as a table: fault x command -> outcome.

Each case writes its files into an empty folder (next to a good recording `good.csv`, a model
`mlr.json` fitted on it and its block `block.scl`), runs the command as a user types it and
expects either exit 2 with one message naming the file and line/column or field, or (for inputs
engineers really produce: BOM, Windows line endings, ';' with decimal commas, units in the header)
success. `tests/test_bad_input.py` runs every row; `python scripts/bad_input_table.py` writes the
table in docs/bad_input.md from the same runs.
"""
from __future__ import annotations

import json
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from tests.cli_runner import thermoplc
from tests.golden_models import GOLDEN, golden_block, golden_twin_csv
from thermoplc.recordings.table import write_table
from thermoplc.machines.cascade import simulate

FIT = ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "--train-rows", "200",
       "-o", "out.json", "--data")
VERIFY = ("verify", "block.scl", "--model", "mlr.json", "--data")
DIAGNOSE = ("diagnose", "--speed", "n_rpm", "--ambient", "T_env", "--temps", "T_motor,T_bearing", "--target", "E_z_um",
            "-o", "out.json", "--data")
SELECT = ("select-sensors", "--target", "E_z_um", "--candidates", "T_motor,T_bearing,T_struct,T_base", "-o", "out.txt",
          "--data")


@dataclass(frozen=True)
class Case:
    category: str
    fault: str
    command: str  # what the table shows
    argv: tuple[str, ...]
    prepare: Callable[[Path], None]
    expect: str  # 'error' (exit 2), 'accepted' (exit 0) or 'refused' (exit 1: verify found a difference or danger)
    message: str  # part of the message (error) or of stdout (accepted, refused)


def good_csv(folder: Path) -> str:
    return (folder / "good.csv").read_text()


def with_text(name: str, make: Callable[[str], str | bytes]):
    def prepare(folder: Path) -> None:
        content = make(good_csv(folder))
        path = folder / name
        path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    return prepare


def _cell(text: str, row: int, column: str, value: str, delimiter: str = ",") -> str:
    lines = text.splitlines()
    header = lines[0].split(delimiter)
    cells = lines[row].split(delimiter)
    cells[header.index(column)] = value
    lines[row] = delimiter.join(cells)
    return "\n".join(lines) + "\n"


def _held_target(text: str, every: int = 30) -> str:
    """The target probed every `every` rows and held between probings, as a lathe's logger records it."""
    lines = text.splitlines()
    column = lines[0].split(",").index("E_z_um")
    rows = [line.split(",") for line in lines[1:]]
    for k, cells in enumerate(rows):
        cells[column] = rows[k - k % every][column]
    return "\n".join([lines[0], *(",".join(cells) for cells in rows)]) + "\n"


def _unprobed_after(text: str, share: float = 0.6) -> str:
    """The target left empty after the first `share` of the rows: every probing in the training part."""
    lines = text.splitlines()
    column = lines[0].split(",").index("E_z_um")
    rows = [line.split(",") for line in lines[1:]]
    for cells in rows[int(share * len(rows)):]:
        cells[column] = ""
    return "\n".join([lines[0], *(",".join(cells) for cells in rows)]) + "\n"


def _rename(text: str, old: str, new: str) -> str:
    head, rest = text.split("\n", 1)
    return ",".join(new if h == old else h for h in head.split(",")) + "\n" + rest


def _drop_column(text: str, column: str) -> str:
    lines = text.splitlines()
    k = lines[0].split(",").index(column)
    return "\n".join(",".join(c for i, c in enumerate(line.split(",")) if i != k) for line in lines) + "\n"


def _german(text: str) -> str:
    return text.replace(",", ";").replace(".", ",")


def _time_step(text: str, row: int, delta: float) -> str:
    lines = text.splitlines()
    cells = lines[row].split(",")
    cells[0] = f"{float(cells[0]) + delta:g}"
    lines[row] = ",".join(cells)
    return "\n".join(lines) + "\n"


def _dated(text: str, form: str, back_at: int | None = None) -> str:
    """The time column written as date-times from 2024-03-01 08:00 (`form`, strftime), as loggers export it; from
    row `back_at` on the clock an hour back (a daylight-saving change written without its UTC offset)."""
    from datetime import datetime, timedelta
    lines = text.splitlines()
    start = datetime(2024, 3, 1, 8, 0, 0)
    for k in range(1, len(lines)):
        time, rest = lines[k].split(",", 1)
        back = timedelta(hours=1) if back_at is not None and k >= back_at else timedelta(0)
        lines[k] = f"{(start + timedelta(seconds=float(time)) - back).strftime(form)},{rest}"
    return "\n".join(lines) + "\n"


def _excel_days(text: str) -> str:
    """The time column as Excel serial days from 2024-03-01 08:00 (45352.3333...), ten decimals as Excel writes them."""
    lines = text.splitlines()
    for k in range(1, len(lines)):
        time, rest = lines[k].split(",", 1)
        lines[k] = f"{45352 + (8 * 3600 + float(time)) / 86400:.10f},{rest}"
    return "\n".join(lines) + "\n"


def _date_beside_clock(text: str, clock_only: bool = False) -> str:
    """A date column before the time column, which holds clock times (as many loggers export them); `clock_only`:
    the clock times without the date column."""
    from datetime import datetime, timedelta
    lines = text.splitlines()
    start = datetime(2024, 3, 1, 23, 0, 0)  # the run crosses midnight
    lines[0] = lines[0] if clock_only else "date," + lines[0]
    for k in range(1, len(lines)):
        time, rest = lines[k].split(",", 1)
        moment = start + timedelta(seconds=float(time))
        lines[k] = f"{'' if clock_only else moment.strftime('%d.%m.%Y') + ','}{moment.strftime('%H:%M:%S')},{rest}"
    return "\n".join(lines) + "\n"


def _units_row(text: str) -> str:
    """A units row under the header, as a logger exports it: s, rpm, °C, µm."""
    head, rest = text.split("\n", 1)
    unit = lambda name: ("s" if name == "time_s" else "rpm" if name.endswith("rpm") else "µm" if name.endswith("_um")
                         else "°C" if name.startswith("T_") else "")
    return head + "\n" + ",".join(unit(name) for name in head.split(",")) + "\n" + rest


def _model_edit(edit: Callable[[dict], None], raw: Callable[[str], str] | None = None):
    def prepare(folder: Path) -> None:
        doc = json.loads((folder / "mlr.json").read_text())
        edit(doc)
        text = json.dumps(doc, indent=2)
        (folder / "bad.json").write_text(raw(text) if raw else text)
    return prepare


def _block_edit(edit: Callable[[str], str]):
    def prepare(folder: Path) -> None:
        (folder / "bad.scl").write_text(edit((folder / "block.scl").read_text()))
    return prepare


def table_entry_edited(text: str, table: str, index: int, value: str) -> str:
    """A block's text with one entry of a read-only table replaced."""
    start = text.index(f"{table} : ")
    entry = list(re.finditer(r"-?\d+\.\d+(?:E[+-]?\d+)?", text[start:text.index("];", start)]))[index]
    return text[:start + entry.start()] + value + text[start + entry.end():]


def _golden_pair(kind: str, edit: Callable[[str], str]):
    """bad.json: the golden model of `kind`; bad.scl: its TIA block edited; golden_twin.csv: its data."""
    def prepare(folder: Path) -> None:
        (folder / "bad.json").write_text((GOLDEN / f"{kind}.json").read_text())
        (folder / "bad.scl").write_text(edit(golden_block(kind, "tia").read_text()))
        golden_twin_csv(folder)
    return prepare


def _set(path: list, value):
    def edit(doc: dict) -> None:
        node = doc
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    return edit


def _delete(key: str):
    return lambda doc: doc.pop(key)


def _csv_cases() -> list[Case]:
    faults = [
        ("empty file", lambda t: "", "error", "bad.csv: file is empty"),
        ("header only", lambda t: t.splitlines()[0] + "\n", "error", "bad.csv: header only, no data rows"),
        ("missing column", lambda t: _drop_column(t, "T_motor"), "error", "no column 'T_motor'"),
        ("duplicated column", lambda t: _rename(t, "T_struct", "T_motor"), "error",
         "bad.csv:1:7: column 'T_motor' appears twice in the header"),
        ("non-numeric cell", lambda t: _cell(t, 5, "T_motor", "abc"), "error",
         "bad.csv:6:5: column 'T_motor': expected a number, found 'abc'"),
        ("NaN cell", lambda t: _cell(t, 5, "T_motor", "nan"), "error",
         "bad.csv:6:5: column 'T_motor': expected a finite number, found 'nan'"),
        ("empty cell", lambda t: _cell(t, 5, "T_motor", ""), "error",
         "bad.csv:6:5: column 'T_motor': expected a number, found ''"),
        ("time not increasing", lambda t: _time_step(t, 8, -20.0), "error",
         "bad.csv:9: column 'time_s': time must increase strictly"),
        ("irregular sampling", lambda t: _time_step(t, 8, 4.0), "error",
         "bad.csv:9: column 'time_s': step 14 s, expected 10 s"),
        ("a field over 131,072 characters", lambda t: _cell(t, 5, "T_motor", "1" * 200000), "error",
         "bad.csv:6: cannot split the line into fields (field larger than field limit"),
        ("a quote that never closes", lambda t: _cell(t, 5, "T_motor", '"20'), "error",
         "fields, expected 13 as in the header (a '\"' opens a quoted field"),
        ("a blank first line", lambda t: "\n" + t, "error", "bad.csv:1: the first line is blank"),
        ("1_000 late in the file", lambda t: _cell(t, 600, "T_motor", "1_000"), "error",
         "bad.csv:601:5: column 'T_motor': expected a number, found '1_000'"),
        ("a '# pause' comment line", lambda t: "\n".join([*t.splitlines()[:300], "# pause", *t.splitlines()[300:]]) + "\n",
         "error", "bad.csv:301: 1 fields, expected 13"),
        ("one data row", lambda t: "\n".join(t.splitlines()[:2]) + "\n", "error", "bad.csv: 1 data row; a fit needs at least 10"),
        ("a cell of 1e308 (beyond REAL)", lambda t: _cell(t, 100, "T_motor", "1e308"), "error",
         "line 101, column 'T_motor': 1e+308 cannot be a temperature input of type REAL"),
        ("#N/A cell (a logger's gap)", lambda t: _cell(t, 5, "T_motor", "#N/A"), "error",
         "bad.csv:6:5: column 'T_motor': expected a number, found '#N/A' (a missing value: give --gaps drop to drop "
         "its row, or --gaps hold:30s to hold the value before it)"),
        ("a date column beside a clock-time column", _date_beside_clock, "accepted", ""),
        ("clock times without a date", lambda t: _date_beside_clock(t, clock_only=True), "error",
         "bad.csv:2: column 'time_s': '23:00:00' is a clock time without a date; expected a date-time, or one date "
         "column beside it (none found)"),
        ("date-times as slashed dates that read both ways", lambda t: _dated(t, "%m/%d/%Y %H:%M:%S"), "error",
         "bad.csv:2: column 'time_s': '03/01/2024 08:00:00' reads as day first and as month first in every row"),
        ("date-times whose clock goes back an hour (DST)", lambda t: _dated(t, "%Y-%m-%d %H:%M:%S", 300), "error",
         "bad.csv:301: column 'time_s': the clock goes back 3590 s here (a daylight-saving change written without "
         "its UTC offset, or a logger reset)"),
        ("ISO 8601 date-times in the time column", lambda t: _dated(t, "%Y-%m-%dT%H:%M:%S"), "accepted", ""),
        ("a units row under the header", _units_row, "accepted", ""),
        ("UTF-8 byte order mark", lambda t: "\ufeff" + t, "accepted", ""),
        ("Windows line endings", lambda t: t.replace("\n", "\r\n"), "accepted", ""),
        ("';' and decimal commas (German Excel)", _german, "accepted", ""),
        ("',' and ';' both in the header", lambda t: t.replace("time_s,", "time_s;", 1), "error",
         "bad.csv:1: the header has both ',' and ';'"),
        ("truncated last line", lambda t: t.rstrip("\n")[:-12] + "\n", "error", "fields, expected 13 as in the header"),
        ("binary garbage", lambda t: bytes(range(256)) * 4, "error", "not a UTF-8 text file"),
    ]
    cases = []
    for fault, make, expect, message in faults:
        for command, argv in (("fit", FIT), ("verify", VERIFY), ("diagnose", DIAGNOSE), ("select-sensors", SELECT)):
            if command in ("diagnose", "select-sensors") and expect == "accepted":
                continue  # the reader is shared; fit and verify show acceptance
            if fault == "irregular sampling" and command == "select-sensors":
                continue  # sensor selection does not depend on the sampling
            if fault in ("one data row", "a cell of 1e308 (beyond REAL)") and command != "fit":
                continue  # what the rows are for decides the message: shown for fit
            shown = message
            if fault == "missing column" and command == "verify":
                shown = "bad.csv: no column 'T_motor' for model input 'T_motor'"
            cases.append(Case("CSV", fault, command, (*argv, "bad.csv"), with_text("bad.csv", make), expect,
                              shown if expect == "error" else ("bit-exact" if command == "verify" else "wrote out.json")))
    cases.append(Case("CSV", "decimal commas with --decimal .", "fit", (*FIT, "bad.csv", "--decimal", "."),
                      with_text("bad.csv", _german), "error", "bad.csv:2:"))
    cases.append(Case("CSV", "--decimal , on a ',' separated file", "fit", (*FIT, "bad.csv", "--decimal", ","),
                      with_text("bad.csv", lambda t: t), "error", "bad.csv:1: --decimal , needs ';' between the columns"))
    cases.append(Case("CSV", "units in the header: T_motor(degC)", "fit",
                      ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor(°C),T_bearing", "--train-rows",
                       "200", "-o", "out.json", "--data", "bad.csv"),
                      with_text("bad.csv", lambda t: _rename(t, "T_motor", "T_motor(°C)")), "accepted", "wrote out.json"))
    gap = with_text("bad.csv", lambda t: _cell(t, 5, "T_motor", "#N/A"))
    for fault, options, expect, message in (
            ("#N/A cell, --gaps hold:30s", ("--gaps", "hold:30s"), "accepted", "wrote out.json"),
            ("#N/A cell, --gaps hold:5s (shorter than a step)", ("--gaps", "hold:5s"), "error",
             "bad.csv:6: column 'T_motor': missing for 10 s since its last value at line 5, longer than --gaps hold:5s "
             "holds (5 s); give a longer hold, --gaps drop, or fill the cells in the export"),
            ("#N/A cell, --gaps drop (a step of two cycles)", ("--gaps", "drop"), "error",
             "bad.csv:7: column 'time_s': step 20 s (--gaps drop dropped the rows between), expected 10 s ±5%; the "
             "block runs on a fixed cycle: give --resample SECONDS"),
            ("#N/A cell, --gaps keep", ("--gaps", "keep"), "error",
             "argument --gaps: expected refuse, drop or hold:DURATION (hold:30s, hold:2min), found 'keep'")):
        cases.append(Case("CSV", fault, "fit", (*FIT, "bad.csv", *options), gap, expect, message))
    cases.append(Case("CSV", "#N/A time, --gaps hold:30s", "fit", (*FIT, "bad.csv", "--gaps", "hold:30s"),
                      with_text("bad.csv", lambda t: _cell(t, 5, "time_s", "#N/A")), "error",
                      "bad.csv:6: column 'time_s': the time is missing; --gaps hold:30s holds measured values, not the "
                      "time: give --gaps drop, or fill the time in the export"))
    cases.append(Case("CSV", "slashed dates that read both ways, --time-format month-first", "fit",
                      (*FIT, "bad.csv", "--time-format", "month-first"),
                      with_text("bad.csv", lambda t: _dated(t, "%m/%d/%Y %H:%M:%S")), "accepted", "wrote out.json"))
    cases.append(Case("CSV", "Excel serial days, --time-format excel", "fit", (*FIT, "bad.csv", "--time-format", "excel"),
                      with_text("bad.csv", _excel_days), "accepted", "wrote out.json"))
    cases.append(Case("CSV", "seconds read with --time-format excel", "fit", (*FIT, "bad.csv", "--time-format", "excel"),
                      with_text("bad.csv", lambda t: t), "error",
                      "bad.csv:2: column 'time_s': --time-format excel reads Excel serial days (45352.5 is 2024-03-01 "
                      "12:00), found 0; expected a day from 1 (1900-01-01) to 2958465 (9999-12-31)"))
    cases.append(Case("CSV", "missing file", "fit", (*FIT, "nothere.csv"), lambda f: None, "error",
                      "nothere.csv: cannot read: no such file"))
    return cases


def _model_cases() -> list[Case]:
    faults = [
        ("malformed JSON", _model_edit(lambda d: None, lambda t: t[:-40]), "malformed JSON"),
        ("not a model file", _model_edit(_set(["format"], "something")), "field 'format' must be 'thermoplc-model'"),
        ("older schema version", _model_edit(_set(["schema_version"], 0)), "schema_version 0 is not supported"),
        ("future schema version", _model_edit(_set(["schema_version"], 99)), "schema_version 99 is not supported"),
        ("missing field", _model_edit(_delete("coefficients")), "field 'coefficients' is missing"),
        ("non-finite coefficient", _model_edit(_set(["coefficients", "beta_1", "f32"], "0x7FC00000")),
         "field 'coefficients.beta_1' must be a finite binary32 value"),
        ("coefficient beyond binary32", _model_edit(_set(["coefficients", "beta_1"], {"f64": 1e39, "f32": "0x7F800000"})),
         "field 'coefficients.beta_1' must be a finite binary32 value"),
        ("hostile block name", _model_edit(_set(["block_name"], 'X" END_FUNCTION_BLOCK')), "field 'block_name'"),
        ("hostile input name", _model_edit(_set(["inputs", 0, "name"], "T1*) END_VAR")), "field 'inputs[0].name'"),
        ("kind that does not match the inputs", _model_edit(_set(["kind"], "kalman")),
         "kind 'kalman' reads an input of role 'speed', and field 'inputs' has none"),
        ("key given twice", _model_edit(lambda d: None, lambda t: t.replace('"kind": "mlr"', '"kind": "kalman", "kind": "mlr"', 1)),
         "key 'kind' appears twice in one object"),
        ("a speed that is also the ambient", _model_edit(_set(["inputs", 0, "role"], "speed,ambient")),
         "field 'inputs[0].role': 'speed,ambient' gives one signal two roles; only an ambient sensor that is also a "
         "regression temperature has two ('temperature,ambient')"),
        ("the roles of one input reversed", _model_edit(_set(["inputs", 0, "role"], "ambient,temperature")),
         "field 'inputs[0].role': 'ambient,temperature' must be written 'temperature,ambient'"),
        ("two inputs on one column", _model_edit(_set(["inputs", 1, "column"], "T_motor")),
         "fields 'inputs[0]' and 'inputs[1]' both read column 'T_motor'; one column holds one signal"),
    ]
    cases = []
    for fault, prepare, message in faults:
        cases.append(Case("model file", fault, "generate", ("generate", "bad.json", "-o", "out.scl"), prepare, "error", message))
        cases.append(Case("model file", fault, "verify", ("verify", "block.scl", "--model", "bad.json", "--data", "good.csv"),
                          prepare, "error", message))
    cases.append(Case("model file", "model fitted on other column names", "verify",
                      ("verify", "block.scl", "--model", "mlr.json", "--data", "bad.csv"),
                      with_text("bad.csv", lambda t: _rename(_rename(t, "T_motor", "t1"), "T_bearing", "t2")), "error",
                      "bad.csv: no column 'T_motor' for model input 'T_motor' (temperature); map it with --inputs T_motor=COLUMN"))
    cases.append(Case("model file", "data sampled at another period", "verify",
                      ("verify", "block.scl", "--model", "mlr.json", "--data", "bad.csv"),
                      with_text("bad.csv", lambda t: write_table({**_columns(t), "time_s": _columns(t)["time_s"] * 2})),
                      "error", "bad.csv: column 'time_s': sampled every 20 s, but the model was fitted for a call every 10 s"))
    speed = _model_edit(lambda d: d["inputs"].append({"name": "n_rpm", "column": "n_rpm", "role": "speed", "unit": "rpm"}))
    cases.append(Case("model file", "an input its kind does not read", "generate", ("generate", "bad.json", "-o", "out.scl"),
                      speed, "error", "bad.json: cannot generate a block: field 'inputs[2]': input 'n_rpm' has role "
                                      "'speed', which a mlr block does not read"))
    cases.append(Case("model file", "an input its kind does not read", "verify",
                      ("verify", "block.scl", "--model", "bad.json", "--data", "good.csv"), speed, "error",
                      "bad.json: field 'inputs[2]': input 'n_rpm' (role 'speed') is not an input of block.scl"))
    return cases


def _columns(text: str) -> dict:
    import numpy as np
    lines = text.splitlines()
    header = lines[0].split(",")
    values = np.array([[float(c) for c in line.split(",")] for line in lines[1:]])
    return {h: values[:, i] for i, h in enumerate(header)}


def _st_cases() -> list[Case]:
    faults = [
        ("syntax error (missing ';')", _block_edit(lambda t: t.replace("#Init := TRUE;", "#Init := TRUE", 1)),
         "bad.scl:", "syntax error"),
        ("unsupported construct (WHILE)", _block_edit(lambda t: t.replace("BEGIN\n", "BEGIN\n    WHILE #Init DO #Init := TRUE; END_WHILE;\n", 1)),
         "bad.scl:", "WHILE loop is not supported"),
        ("undeclared variable", _block_edit(lambda t: t.replace("#Init := TRUE;", "#Inti := TRUE;", 1)),
         "bad.scl:", "Inti is not declared"),
        ("interface does not match the data", _block_edit(lambda t: t.replace("      T_bearing : Real;", "      T_bearing : Real;\n      T_spare : Real;", 1)),
         "bad.scl:", "T_spare"),
    ]
    def latin1(folder: Path) -> None:  # a comment edited in an editor that saves Windows-1252
        text = (folder / "block.scl").read_text().replace("BEGIN\n", "BEGIN\n    // geändert\n", 1)
        (folder / "bad.scl").write_bytes(text.encode("cp1252"))
    faults.append(("saved as Windows-1252 (an umlaut)", latin1, "bad.scl:", "is not UTF-8 text; a block is read as "
                   "Structured Text or PLCopen XML in UTF-8, or in UTF-16/32 with a byte order mark"))
    cases = []
    for fault, prepare, where, message in faults:
        cases.append(Case("ST file", fault, "verify", ("verify", "bad.scl", "--model", "mlr.json", "--data", "good.csv"),
                          prepare, "error", message))
        cases.append(Case("ST file", fault, "diff", ("diff", "block.scl", "bad.scl", "--data", "good.csv"),
                          prepare, "error", message))
    cases.append(Case("ST file", "safety limits declared in VAR, not VAR CONSTANT", "verify",  # diff lists them, exit 1
                      ("verify", "bad.scl", "--model", "mlr.json", "--data", "good.csv"),
                      _block_edit(lambda t: t.replace("VAR CONSTANT", "VAR", 1)), "error",
                      "bad.scl: c_TempMin, c_TempMax, c_JumpMax, c_SettleCalls, c_OneCall, c_StuckCalls, c_StepMax, "
                      "c_StepMin, c_OutMax, c_OutMin, c_K0_mm, c_RealMax, c_FaultMove, c_FaultFade, c_FaultFloor"))
    return cases


HOSTILE = [
    ("T1; END_FUNCTION_BLOCK", "error", "the header has both ',' and ';'"),  # a ';' in a ',' header is ambiguous
    ("T1 END_FUNCTION_BLOCK", "accepted", "wrote out.json"),  # becomes the identifier T1_END_FUNCTION_BLOCK
    ("T*)x", "accepted", "wrote out.json"),
    ('T"1', "accepted", "wrote out.json"),
    ("#T1", "accepted", "column '#T1' is block name T1_in"),  # timer 1 in classic SCL: renamed, stated
    ("#T_1", "accepted", "wrote out.json"),
    ("METHOD", "accepted", "column 'METHOD' is block name METHOD_in"),
    ("Т1", "accepted", "column 'Т1' is block name in_1"),  # a Cyrillic T
    ("T" * 200, "accepted", "is block name TTTTTTTTTTTTTTTTT_"),
    ("TON", "accepted", "column 'TON' is block name TON_in"),
    ("EXP", "accepted", "column 'EXP' is block name EXP_in"),
    ("BEGIN", "accepted", "column 'BEGIN' is block name BEGIN_in"),
]


def _injection_cases() -> list[Case]:
    cases = []
    for name, expect, message in HOSTILE:
        shown = name if len(name) < 40 else name[:12] + f"... ({len(name)} characters)"
        cases.append(Case("injection", f"column named {shown!r}", "fit",
                          ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", f"{name},T_bearing", "--train-rows",
                           "200", "-o", "out.json", "--data", "bad.csv"),
                          with_text("bad.csv", lambda t, n=name: _rename(t, "T_motor", n)), expect, message))
    cases.append(Case("injection", "block name with a quote and END_FUNCTION_BLOCK", "fit",
                      (*FIT, "good.csv", "--name", 'X" END_FUNCTION_BLOCK'), lambda f: None, "error", "block name"))
    return cases


def _output_cases() -> list[Case]:
    """Issue 15: one overwrite rule, never onto an input, never onto a non-regular file, report folders."""
    def foreign(folder: Path) -> None:
        (folder / "out.scl").write_text("my own notes\n")

    def own(folder: Path) -> None:
        (folder / "out.scl").write_text((folder / "block.scl").read_text())

    def linked(folder: Path) -> None:
        (folder / "notes.txt").write_text("my own notes\n")
        (folder / "out.scl").symlink_to("notes.txt")

    def foreign_report(folder: Path) -> None:
        (folder / "rep").mkdir()
        (folder / "rep" / "channel_1.png").write_text("my own picture")

    def own_report_with_a_foreign_file(folder: Path) -> None:
        (folder / "rep").mkdir()
        (folder / "rep" / ".thermoplc-report").write_text("index.html\n")
        (folder / "rep" / "channel_1.png").write_text("my own picture")

    generate = ("generate", "mlr.json", "-o", "out.scl")
    select = ("select-sensors", "--data", "good.csv", "--target", "E_z_um", "--candidates", "T_motor,T_bearing,T_env")
    return [
        Case("output", "output exists, not written by thermoplc", "generate", generate, foreign, "error",
             "out.scl: exists; refusing to replace it"),
        Case("output", "output exists, a block thermoplc wrote", "generate", generate, own, "error",
             "out.scl: exists; refusing to replace it"),
        Case("output", "same, with --force", "generate", (*generate, "--force"), foreign, "accepted", "wrote out.scl"),
        Case("output", "output is a folder", "generate", ("generate", "mlr.json", "-o", "."), lambda f: None, "error",
             ": is a folder"),
        Case("output", "output is the model read, with --force", "generate",
             ("generate", "mlr.json", "-o", "mlr.json", "--force"), lambda f: None, "error",
             "mlr.json: is also an input of this command"),
        Case("output", "output is the recording read, with --force", "fit", (*FIT[:-3], "-o", "good.csv", "--force",
             "--data", "good.csv"), lambda f: None, "error", "good.csv: is also an input of this command"),
        Case("output", "output is the recording read", "select-sensors", (*select, "-o", "good.csv", "--force"),
             lambda f: None, "error", "good.csv: is also an input of this command"),
        Case("output", "output is a device, with --force", "generate", ("generate", "mlr.json", "-o", "/dev/null",
             "--force"), lambda f: None, "error", "/dev/null: exists and is not a regular file"),
        Case("output", "output is a symbolic link, with --force", "generate", (*generate, "--force"), linked, "error",
             "out.scl: exists and is not a regular file"),
        Case("output", "report folder not empty and not a report", "diagnose", (*DIAGNOSE, "good.csv", "--report", "rep"),
             foreign_report, "error", "--report rep: is not empty and is not a report thermoplc wrote"),
        Case("output", "-o naming the report's own index.html", "diagnose",
             (*DIAGNOSE[:-3], "-o", "rep/index.html", "--data", "good.csv", "--report", "rep"), lambda f: None, "error",
             "rep/index.html: is inside the --report folder rep"),
        Case("output", "report folder of thermoplc holding a file it does not list", "diagnose",
             (*DIAGNOSE, "good.csv", "--report", "rep"), own_report_with_a_foreign_file, "error",
             "channel_1.png exists and is not listed"),
        Case("campaign", "--train-runs leaving no held-out run", "diagnose",
             (*DIAGNOSE, "good.csv", "--data", "b.csv", "--train-runs", "2"), _second_run, "error",
             "--train-runs 2: the campaign has 2 runs; both the training runs and the held-out runs need at least one"),
        Case("campaign", "--train-until on a campaign", "diagnose",
             (*DIAGNOSE, "good.csv", "--data", "b.csv", "--train-until", "3600"), _second_run, "error",
             "--train-until/--train-rows split one recording; this campaign has 2 runs"),
        Case("campaign", "--train-runs with one recording", "diagnose", (*DIAGNOSE, "good.csv", "--train-runs", "1"),
             lambda f: None, "error", "--train-runs 1: only one run was given"),
        Case("campaign", "a run that is a copy of another", "diagnose", (*DIAGNOSE, "good.csv", "--data", "b.csv"),
             lambda f: (f / "b.csv").write_bytes((f / "good.csv").read_bytes()), "error",
             "b.csv: the same recording as good.csv (its very bytes); a run held out against its own copy is not held out"),
        Case("campaign", "a target held between probings, no --held-target", "diagnose", (*DIAGNOSE, "held.csv"),
             with_text("held.csv", _held_target), "error",
             "held.csv: column 'E_z_um': 97% of its values repeat the one before (a drift probed and held between "
             "probings?); give --held-target"),
        Case("campaign", "a probed target never measured in the held-out part", "diagnose", (*DIAGNOSE, "late.csv"),
             with_text("late.csv", _unprobed_after), "error",
             "column 'E_z_um': measured 0 time(s) in the held-out part; diagnose needs at least 10 probings there"),
    ]


def _other_run(_: str = "") -> str:
    """Another run of the machine good.csv was recorded on (another seed): a copy of good.csv, even one cell
    apart, is refused as the same recording (fitting/copies.py)."""
    return write_table(simulate(2, seed=5))


def _second_run(folder: Path) -> None:
    (folder / "b.csv").write_text(_other_run(), encoding="utf-8")


def _swap_nodes(doc: dict) -> None:
    first, last = doc["coefficients"]["node_1"], doc["coefficients"]["node_4"]
    doc["coefficients"]["node_1"], doc["coefficients"]["node_4"] = last, first


def _schema_cases() -> list[Case]:
    """Issue 15: mistyped settings of every kind, caught by the schema or the shape checks, never a traceback."""
    rows = [
        ("dlag", "lags as text", ["settings", "lags"], "3", "field 'settings.lags': '3' is not of type 'integer'"),
        ("dlag", "lags as a fraction", ["settings", "lags"], 3.5, "field 'settings.lags': 3.5 is not of type 'integer'"),
        ("dlag", "lag step of 0 samples", ["settings", "lag_step_samples"], 0, "'settings.lag_step_samples': 0 is less"),
        ("lumped", "effects as text", ["settings", "effects"], "abc", "field 'settings.effects' must be a list"),
        ("lumped", "relay sensor that does not exist", ["settings", "relay_sensor"], 9,
         "field 'settings.relay_sensor': 9 but the model has 2 temperature inputs"),
        ("lumped", "nonlinear_speed_heat without its speed table", ["settings", "speed_table_segments"], 0,
         "field 'settings.speed_table_segments': 0, but settings.effects lists nonlinear_speed_heat"),
        ("lumped", "speed table of 15 segments holding 16 rows", ["settings", "speed_table_segments"], 15,
         "field 'settings.speed_table_segments': 15, but the file has 16 node_ coefficients"),
        ("lumped", "gear heat lag that never decays", ["coefficients", "AGr"], {"f64": 1.0, "f32": "0x3F800000"},
         "field 'coefficients.AGr': 1.0; expected a decay per call exp(-dt/tau) in [0, 1)"),
        ("lumped", "sensor lag that grows", ["coefficients", "A_1"], {"f64": 1.25, "f32": "0x3FA00000"},
         "field 'coefficients.A_1': 1.25; expected a decay per call exp(-dt/tau) in [0, 1)"),
        ("mlr", "no inputs", ["inputs"], [], "field 'inputs': [] should be non-empty"),
        ("bayes", "configurations that do not fit the intervals", ["settings", "configurations"], 2,
         "intervals [8, 8] and configurations 2 do not fit 2 parents"),
        ("bayes", "an interval count as text", ["settings", "intervals"], [2, "x"],
         "field 'settings.intervals[1]': 'x' is not of type 'integer'"),
        ("bayes", "unknown unseen rule", ["settings", "unseen"], "guess", "field 'settings.unseen': 'guess' is not one of"),
        ("bpnn", "no hidden neurons", ["settings", "hidden"], 0, "field 'settings.hidden': 0 is less than the minimum of 1"),
        ("bpnn", "more network inputs than sensors", ["settings", "inputs"], 3,
         "inputs 3 and outputs 3 must be the 2 temperature inputs"),
        ("kalman", "negative sample period", ["sample_period_s"], -1, "field 'sample_period_s': -1 is less than the minimum"),
        ("mlr", "sample period 1e-300 s", ["sample_period_s"], 1e-300,
         "field 'sample_period_s': 1e-300 is less than the minimum of 0.0001"),
        ("piecewise", "nodes as an object", ["settings", "nodes"], {}, "field 'settings.nodes': {} is not of type 'array'"),
        ("gm1n", "coefficient f32 not hex", ["coefficients", "Keep", "f32"], "0xZZZZZZZZ", "field 'coefficients.Keep.f32'"),
    ]
    cases = [Case("model file", f"{kind}: {fault}", "generate", ("generate", "bad.json", "-o", "out.scl"),
                  _golden_edit(kind, _set(path, value)), "error", message) for kind, fault, path, value, message in rows]
    cases.append(Case("model file", "lumped: cooling lag without its other half", "generate",
                      ("generate", "bad.json", "-o", "out.scl"),
                      _golden_edit("lumped", lambda doc: doc["coefficients"].pop("BCl")), "error",
                      "field 'coefficients': ACl without BCl; the cooling's lag needs both"))

    def deep(folder: Path) -> None:
        (folder / "bad.json").write_text("[" * 100000 + "]" * 100000)

    def huge_number(folder: Path) -> None:
        (folder / "bad.json").write_text((folder / "mlr.json").read_text().replace('"sample_period_s": 10.0',
                                                                                     '"sample_period_s": ' + "9" * 5000))
    cases += [Case("model file", "JSON nested 100,000 levels", "generate", ("generate", "bad.json", "-o", "out.scl"), deep,
                   "error", "JSON nested thousands of levels deep"),
              Case("model file", "a 5000-digit number", "generate", ("generate", "bad.json", "-o", "out.scl"), huge_number,
                   "error", "cannot read a number: Exceeds the limit (4300 digits)")]
    return cases


def _nesting_cases() -> list[Case]:
    """Issue 15: ST nested beyond any sensible block, named instead of a RecursionError traceback."""
    def deep_expression(t: str) -> str:
        return t.replace("#Init := TRUE;", "#Init := " + "NOT " * 20000 + "TRUE;", 1)

    def long_sum(t: str) -> str:
        return t.replace("#Init := TRUE;", "#Delta := " + " + ".join(["#Delta"] * 2000) + ";\n#Init := TRUE;", 1)

    def nested_ifs(t: str) -> str:
        return t.replace("#Init := TRUE;", "IF TRUE THEN " * 3000 + "#Init := TRUE;" + " END_IF;" * 3000, 1)
    bad_block = ("verify", "bad.scl", "--model", "mlr.json", "--data", "good.csv")
    return [Case("ST file", fault, "verify", bad_block, _block_edit(edit), "error", message) for fault, edit, message in (
        ("20,000 NOTs", deep_expression, "bad.scl: expressions or statements nested too deeply"),
        ("a sum of 2000 terms", long_sum, "bad.scl: expressions or statements nested too deeply"),
        ("3000 nested IFs", nested_ifs, "nested too deeply"))]


def _data_file_cases() -> list[Case]:
    """Issue 15: .npz files that are not what they claim, and inputs a model does not have."""
    def garbage_npz(folder: Path) -> None:
        (folder / "bad.npz").write_bytes(b"PK\x03\x04" + b"garbage" * 10)

    def csv_as_npz(folder: Path) -> None:
        (folder / "bad.npz").write_text(good_csv(folder))

    def reset_of_two(folder: Path) -> None:
        lines = good_csv(folder).splitlines()
        rows = [lines[0] + ",Reset", *(line + (",2" if k == 3 else ",0") for k, line in enumerate(lines[1:]))]
        (folder / "bad.csv").write_text("\n".join(rows) + "\n")

    return [
        Case("data file", ".npz with garbage after the zip magic", "verify", (*VERIFY, "bad.npz"), garbage_npz, "error",
             "bad.npz: cannot read as .npz: File is not a zip file"),
        Case("data file", "a CSV named .npz", "verify", (*VERIFY, "bad.npz"), csv_as_npz, "error",
             "bad.npz: not a .npz archive (it does not start as a zip file)"),
        Case("data file", "--inputs naming an input the model lacks", "verify",
             (*VERIFY, "good.csv", "--inputs", "Nope=T_motor"), lambda f: None, "error",
             "--inputs maps Nope, but mlr.json has no such input"),
        Case("data file", "a Reset column holding 2", "verify", (*VERIFY, "bad.csv"), reset_of_two, "error",
             "bad.csv: line 5, column 'Reset': 2 cannot be the Reset input (BOOL); expected 0 or 1"),
        Case("data file", "--inputs Enable= a column the file lacks", "verify",
             (*VERIFY, "good.csv", "--inputs", "Enable=en_cmd"), lambda f: None, "error",
             "good.csv: no column 'en_cmd' for block input 'Enable'"),
    ]


def _bounded_cases() -> list[Case]:
    """Issue 15: inputs that would take the machine's memory or minutes are refused at once."""
    huge_array = _block_edit(lambda t: t.replace("VAR_TEMP", "VAR_TEMP\n      Huge : Array[0..2000000000] of Real;", 1))
    long_comment = _block_edit(lambda t: "(*" + "x" * 5_000_000 + "*)\n" + t)
    bad_block = ("verify", "bad.scl", "--model", "mlr.json", "--data", "good.csv")
    return [
        Case("model file", "piecewise nodes out of order", "generate", ("generate", "bad.json", "-o", "out.scl"),
             _golden_edit("piecewise", _swap_nodes), "error", "strictly increasing"),
        Case("ST file", "ARRAY[0..2000000000]", "verify", bad_block, huge_array, "error",
             "ARRAY[0..2000000000] has 2,000,000,001 elements"),
        Case("ST file", "a 5 MB comment", "verify", bad_block, long_comment, "error",
             "a function block source is at most 4,000,000 here"),
    ]


def _replaced_block(version: str):
    """out.scl: a block thermoplc wrote (of another model than mlr.json) at VERSION `version`."""
    def prepare(folder: Path) -> None:
        text = golden_block("mlr", "tia").read_text()
        (folder / "out.scl").write_text(text.replace("VERSION : 0.1\n", f"VERSION : {version}\n", 1))
    return prepare


def _option_cases() -> list[Case]:
    """Issue 15: every numeric option checked when the command line is read, naming option and range."""
    fit = lambda *extra: ("fit", "--data", "good.csv", "--target", "E_z_um", "--temps", "T_motor,T_bearing", *extra,
                          "-o", "out.json")
    kalman = ("--model", "kalman", "--speed", "n_rpm", "--ambient", "T_env", "--train-rows", "200")
    rows = [
        ("--population 0", fit(*kalman, "--population", "0"), "argument --population: expected individuals from 2"),
        ("--generations -1", fit(*kalman, "--generations", "-1"), "argument --generations: expected generations from 1"),
        ("--precision-um nan", fit("--model", "bayes", "--train-rows", "200", "--precision-um", "nan"),
         "argument --precision-um: expected micrometres from 0.001"),
        ("--lag-step nan", fit("--model", "dlag", "--train-rows", "200", "--lag-step", "nan"),
         "argument --lag-step: expected seconds"),
        ("--lags 100000", fit("--model", "dlag", "--train-rows", "200", "--lags", "100000"),
         "argument --lags: expected lags from 1 to 1,000"),
        ("--train-until nan", fit("--model", "mlr", "--train-until", "nan"), "argument --train-until: expected seconds"),
        ("--train-rows 0", fit("--model", "mlr", "--train-rows", "0"), "argument --train-rows: expected a row count"),
        ("--seed -1", fit(*kalman, "--seed", "-1"), "argument --seed: expected a seed"),
        ("--ambient the --speed column", fit("--model", "kalman", "--speed", "n_rpm", "--ambient", "n_rpm", "--train-rows",
                                             "200"),
         "--ambient n_rpm: the column is already the speed input; one column holds one signal"),
    ]
    cases = [Case("option", fault, "fit", argv, lambda f: None, "error", message) for fault, argv, message in rows]
    generate = ("generate", "mlr.json", "-o", "out.scl")
    for fault, extra, message in (
            ("--temp-range 150,-40", ("--temp-range", "150,-40"), "argument --temp-range: expected LOW,HIGH with LOW below"),
            ("--max-offset-um 1e39", ("--max-offset-um", "1e39"), "argument --max-offset-um: expected micrometres"),
            ("--settle-calls 0", ("--settle-calls", "0"), "argument --settle-calls: expected calls from 1"),
            ("--stuck-calls 1", ("--stuck-calls", "1"), "argument --stuck-calls: expected calls from 2"),
            ("--max-step-um inf", ("--max-step-um", "inf"), "argument --max-step-um: expected micrometres")):
        cases.append(Case("option", fault, "generate", (*generate, *extra), lambda f: None, "error", message))
    select = ("select-sensors", "--data", "good.csv", "--target", "E_z_um", "--candidates", "T_motor,T_bearing")
    more = [
        ("fit", "--jump-limit -1", fit(*kalman, "--jump-limit", "-1"), "argument --jump-limit: expected kelvin"),
        ("fit", "--recover-limit nan", fit(*kalman, "--recover-limit", "nan"), "argument --recover-limit: expected kelvin"),
        ("fit", "--bins 0", fit("--model", "bayes", "--train-rows", "200", "--bins", "0"), "argument --bins: expected intervals"),
        ("fit", "--time-bins -1", fit("--model", "bayes", "--train-rows", "200", "--time-bins", "-1"),
         "argument --time-bins: expected intervals from 0"),
        ("fit", "--lags 0", fit("--model", "dlag", "--train-rows", "200", "--lags", "0"), "argument --lags: expected lags from 1"),
        ("twin", "--dt 0", ("twin", "--dt", "0", "-o", "out.csv"), "argument --dt: expected seconds"),
        ("twin", "--noise -1", ("twin", "--noise", "-1", "-o", "out.csv"), "argument --noise: expected a scale from 0"),
        ("twin", "--ambient-start 100", ("twin", "--ambient-start", "100", "-o", "out.csv"),
         "argument --ambient-start: expected degC from -40 to 60"),
        ("twin", "--seed abc", ("twin", "--seed", "abc", "-o", "out.csv"), "argument --seed: expected an integer, found 'abc'"),
        ("generate", "--max-jump-k 0", (*generate, "--max-jump-k", "0"), "argument --max-jump-k: expected kelvin"),
        ("generate", "--temp-range 0,1e-40 (a subnormal end)", (*generate, "--temp-range", "0,1e-40"),
         "each 0 or at least 1e-6 in size"),
        ("generate", "--temp-range abc", (*generate, "--temp-range", "abc"), "expected LOW,HIGH (two numbers), found 'abc'"),
        ("verify", "--jobs 1000", ("verify", "--manifest", "m.csv", "--jobs", "1000"), "argument --jobs: expected processes"),
        ("verify", "--scheduler that is no address", ("verify", "--manifest", "m.csv", "--scheduler", "localhost"),
         "argument --scheduler: expected a Dask scheduler's address tcp://HOST:PORT, found 'localhost'"),
        ("verify", "--scheduler beside --jobs", ("verify", "--manifest", "m.csv", "--scheduler", "tcp://127.0.0.1:8786",
                                                  "--jobs", "2"), "--scheduler and --jobs"),
        ("fit", "--scheduler without folds", fit("--model", "mlr", "--train-rows", "200", "--scheduler",
                                                 "tcp://127.0.0.1:1"), "--scheduler runs the folds of --folds or"),
        ("fit", "--scheduler where nothing answers", fit("--model", "mlr", "--folds", "3", "--scheduler",
                                                         "tcp://127.0.0.1:1"),
         "--scheduler tcp://127.0.0.1:1: cannot reach a Dask scheduler there"),
        ("diagnose", "--scheduler that is no address", (*DIAGNOSE, "good.csv", "--scheduler", "tcp://:8786"),
         "argument --scheduler: expected a Dask scheduler's address tcp://HOST:PORT, found 'tcp://:8786'"),
        ("select-sensors", "--max-groups 0", (*select, "--max-groups", "0"), "argument --max-groups: expected groups from 1"),
        ("select-sensors", "--threshold 2", (*select, "--threshold", "2"), "argument --threshold: expected a degree from 0 to 1"),
    ]
    cases += [Case("option", fault, command, argv, lambda f: None, "error", message) for command, fault, argv, message in more]
    cases += [
        Case("option", "--train-rows 0", "select-sensors", (*select, "--train-rows", "0"), lambda f: None, "error",
             "argument --train-rows: expected a row count"),
        Case("option", "--train-rows beyond the file", "select-sensors", (*select, "--train-rows", "99999"),
             lambda f: None, "error", "--train-rows 99999 asks for 99999 training rows; the file has 721"),
        Case("option", "--author with a blank", "generate", (*generate, "--author", "ACME Corp"), lambda f: None,
             "error", "argument --author: expected a letter, then letters, digits or '_', 8 characters at most"),
        Case("option", "--family longer than STEP 7 takes", "generate", (*generate, "--family", "ThermalFamily"),
             lambda f: None, "error", "argument --family: expected a letter"),
        Case("option", "--block-version 16.0", "generate", (*generate, "--block-version", "16.0"), lambda f: None,
             "error", "argument --block-version: expected X.Y with each part 0 to 15"),
        Case("option", "--date 2026-02-30", "generate", (*generate, "--date", "2026-02-30"), lambda f: None,
             "error", "argument --date: expected a date YYYY-MM-DD"),
        Case("option", "--instance-db for TIA", "generate", (*generate, "--instance-db", "ThermDB"), lambda f: None,
             "error", "--instance-db writes a STEP 7 instance DB source"),
        Case("option", "--instance-db named like the block", "generate",
             (*generate, "--dialect", "step7", "--instance-db", "thermalcomp"), lambda f: None, "error",
             "instance DB name 'thermalcomp' is the block's own name"),
        Case("option", "--instance-db longer than a STEP 7 symbol", "generate",
             (*generate, "--dialect", "step7", "--instance-db", "Thermal_DB_of_the_axis_Z1"), lambda f: None, "error",
             "argument --instance-db: 'Thermal_DB_of_the_axis_Z1' has 25 characters, at most 24 are allowed"),
        Case("option", "--name longer than a STEP 7 symbol", "generate",
             (*generate, "--name", "ThermalCompensation_AxZ12"), lambda f: None, "error",
             "--name 'ThermalCompensation_AxZ12' has 25 characters, at most 24 are allowed"),
        Case("option", "--header-name longer than STEP 7 takes", "generate", (*generate, "--header-name", "ThermalComp"),
             lambda f: None, "error", "argument --header-name: expected a letter, then letters, digits or '_', 8 characters"),
        Case("option", "a block name whose 8-character NAME is a reserved word", "generate",
             (*generate, "--dialect", "step7", "--name", "Function_Axis"), lambda f: None, "error",
             "NAME 'Function' (the block name cut to the 8 characters STEP 7 allows): 'Function' is a reserved word"),
        Case("option", "-o replaces a block at VERSION 15.15 with a changed model", "generate", (*generate, "--force"),
             _replaced_block("15.15"), "error", "out.scl is VERSION 15.15, the last a block header takes"),
        Case("option", "-o replaces a block whose VERSION was edited to 16.3", "generate", (*generate, "--force"),
             _replaced_block("16.3"), "error", "out.scl is a block thermoplc wrote, but its VERSION 16.3 is outside"),
        Case("option", "select-sensors --candidates with the target's twin", "select-sensors",
             (*select[:-1], "T_motor,E_z_true_um"), lambda f: None, "error",
             "--candidates column 'E_z_true_um' is named like the target 'E_z_um'"),
        Case("option", "fit --temps with a feed rate", "fit",
             ("fit", "--data", "good.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,v_feed_mm_min",
              "--train-rows", "200", "-o", "out.json"), lambda f: None, "error",
             "cannot be a temperature (--temps;"),
        Case("option", "--hours nan", "twin", ("twin", "--hours", "nan", "-o", "out.csv"), lambda f: None, "error",
             "argument --hours: expected hours"),
        Case("option", "--jobs 0", "verify", ("verify", "--manifest", "m.csv", "--jobs", "0"), lambda f: None, "error",
             "argument --jobs: expected processes from 1"),
        Case("option", "--bins for --model mlr", "fit", (*FIT, "good.csv", "--bins", "12"), lambda f: None, "error",
             "--bins is read by --model bayes only; --model mlr does not read it, leave it out"),
        Case("option", "--optimizer for --model auto without the roles kalman needs", "fit",
             ("fit", "--data", "good.csv", "--model", "auto", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
              "--train-rows", "200", "--optimizer", "de", "-o", "out.json"), lambda f: None, "error",
             "--optimizer is read by --model kalman only, which --model auto does not try here (kalman needs --speed "
             "and --ambient)"),
        Case("option", "--temps with an empty name", "fit",
             ("fit", "--data", "good.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,,T_bearing",
              "--train-rows", "200", "-o", "out.json"), lambda f: None, "error",
             "argument --temps: an empty column name in 'T_motor,,T_bearing'"),
        Case("option", "--speed with a typo for a kind that does not read it", "fit",
             (*FIT, "good.csv", "--speed", "n_rpmm"), lambda f: None, "error",
             "no column 'n_rpmm' (did you mean 'n_rpm'?)"),
        Case("option", "--choose-sensors 0", "fit", (*FIT, "good.csv", "--choose-sensors", "0"), lambda f: None,
             "error", "argument --choose-sensors: expected sensors from 1 to 64, found 0"),
        Case("option", "--choose-sensors with --model auto", "fit",
             ("fit", "--data", "good.csv", "--model", "auto", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
              "--train-rows", "200", "--choose-sensors", "2", "-o", "out.json"), lambda f: None, "error",
             "--choose-sensors is for one kind: --model auto chooses its sensor sets itself"),
        Case("option", "--choose-sensors on 30 training rows", "fit",
             ("fit", "--data", "good.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
              "--train-rows", "30", "--choose-sensors", "1", "-o", "out.json"), lambda f: None, "error",
             "--choose-sensors: 30 measured training rows; choosing sensors on one recording fits two thirds"),
    ]
    return cases


COUNTER = """FUNCTION_BLOCK Counter
VAR_INPUT x : INT; END_VAR
VAR_OUTPUT i : DINT; flag : BOOL; END_VAR
i := x * x * x;
flag := x > 0;
END_FUNCTION_BLOCK
"""


def _counter_trace(x: list, i: list, flag: list):
    def prepare(folder: Path) -> None:
        (folder / "bad.st").write_text(COUNTER)
        (folder / "bad.csv").write_text(write_table({"time_s": [10.0 * k for k in range(len(x))], "x": x,
                                                     "i_plc": i, "flag_plc": flag}))
    return prepare


def _golden_edit(kind: str, edit: Callable[[dict], None]):
    def prepare(folder: Path) -> None:
        doc = json.loads((GOLDEN / f"{kind}.json").read_text())
        edit(doc)
        (folder / "bad.json").write_text(json.dumps(doc, indent=2))
    return prepare


def _rendered(prepare: Callable[[Path], None]):
    """bad.json as `prepare` writes it, and bad.scl rendered from it without generate's checks."""
    def both(folder: Path) -> None:
        from thermoplc.generator.lower import lower
        from thermoplc.generator.printer import render
        from thermoplc.models.modelfile import load_model
        prepare(folder)
        (folder / "bad.scl").write_text(render(lower(load_model(folder / "bad.json")), "tia"))
    return both


def _zero_noise(doc: dict) -> None:
    for name in ("N_1", "R_1", "P0_1"):
        doc["coefficients"][name] = {"f64": 0.0, "f32": "0x00000000"}


def _verify_cases() -> list[Case]:
    """Issue 13: what verify or generate must never let through."""
    expect = ("verify", "bad.st", "--data", "bad.csv", "--expect", "i=i_plc,flag=flag_plc")
    overflowing = {"f64": 3e38, "f32": "0x7F61B1E6"}
    return [
        Case("model file", "effect name carrying a quote and statements", "generate", ("generate", "bad.json", "-o", "out.scl"),
             _model_edit(_set(["settings", "effects"], [{"name": "x' BEGIN E_z_um := 250.0; END_FUNCTION_BLOCK //"}])),
             "error", "field 'settings.effects[0].name' must be one of"),
        Case("model file", "input named like the block's own Ready", "generate", ("generate", "bad.json", "-o", "out.scl"),
             _model_edit(lambda doc: (_set(["inputs", 0, "name"], "Ready")(doc), doc.pop("plausibility", None))), "error",
             "'Ready' and 'Ready' are the same identifier"),
        Case("trace", "--expect Fault_1, the name of a fault bit before they were named after the sensor", "verify",
             ("verify", "block.scl", "--data", "good.csv", "--expect", "E_z_um=E_z_um,Fault_1=plc_F1"), lambda f: None,
             "error", "Fault_1 of a block generated before that is Fault_T_motor here: --expect Fault_T_motor=plc_F1"),
        Case("model file", "Kalman noise constants of 0", "generate", ("generate", "bad.json", "-o", "out.scl"),
             _golden_edit("kalman", _zero_noise), "error", "the Kalman filter needs it > 0"),
        Case("model file", "dlag ring buffer longer than an INT indexes", "generate", ("generate", "bad.json", "-o", "out.scl"),
             _golden_edit("dlag", _set(["settings", "lag_step_samples"], 33000)), "error", "does not fit INT"),
        Case("model file", "coefficients that overflow REAL", "generate", ("generate", "bad.json", "-o", "out.scl"),
             _model_edit(_set(["coefficients", "beta_1"], overflowing)), "error", "range proof fails"),
        Case("model file", "Kalman measurement noise so large the gain underflows", "generate", ("generate", "bad.json", "-o",
             "out.scl"), _golden_edit("kalman", _set(["coefficients", "R_1"], overflowing)), "error", "underflow to 0"),
        Case("model file", "held out worse than no compensation", "generate", ("generate", "bad.json", "-o", "out.scl"),
             _model_edit(_set(["metrics", "held_out", "rmse_um"], 1000.0)), "error", "not clearly better than no compensation"),
        Case("model file", "no held-out rows", "generate", ("generate", "bad.json", "-o", "out.scl"),
             _model_edit(_set(["metrics", "held_out", "rows"], 0)), "error", "carries no held-out evidence"),
        Case("model file", "same, with --accept-unvalidated", "generate",
             ("generate", "bad.json", "-o", "out.scl", "--accept-unvalidated"),
             _model_edit(_set(["metrics", "held_out", "rows"], 0)), "accepted", "wrote out.scl"),
        Case("model file", "float32 block far from the float64 model", "generate",
             ("generate", "bad.json", "-o", "out.scl", "--accept-unvalidated"),
             _model_edit(_set(["metrics", "float32_vs_float64_max_um"], 100.0)), "error",
             "the block is not the model that was judged"),
        Case("model file", "subnormal coefficient", "generate", ("generate", "bad.json", "-o", "out.scl"),
             _model_edit(_set(["coefficients", "beta_1"], {"f64": 1e-40, "f32": "0x000116C2"})), "error",
             "constant c_beta_1 = 9.99994610111476e-41 is subnormal"),
        Case("model file", "subnormal coefficient, block written past generate", "verify",
             ("verify", "bad.scl", "--model", "bad.json", "--data", "good.csv"),
             _rendered(_model_edit(_set(["coefficients", "beta_1"], {"f64": 1e-40, "f32": "0x000116C2"}))), "refused",
             "NOT verified"),
        Case("model file", "coefficients that overflow REAL, block written past generate", "verify",
             ("verify", "bad.scl", "--model", "bad.json", "--data", "good.csv"),
             _rendered(_model_edit(_set(["coefficients", "beta_1"], overflowing))), "refused", "NOT verified"),
        Case("ST file", "statements after a quoted TITLE", "verify", ("verify", "bad.scl", "--model", "mlr.json", "--data",
             "good.csv"), _block_edit(lambda t: t.replace("\n", "\nTITLE = 'x' #E_z_um := 250.0;\n", 1)), "error",
             "syntax error"),
        Case("ST file", "integer literal beyond DINT", "verify", ("verify", "bad.scl", "--model", "mlr.json", "--data",
             "good.csv"), _block_edit(lambda t: t.replace("#Init := TRUE;", "#Init := 12345678901234567890123456 > 0;", 1)),
             "error", "does not fit DINT"),
        Case("trace", "INT input holding 2.5", "verify", expect, _counter_trace([1, 2.5], [1, 8], [1, 1]), "error",
             "column 'x': 2.5 cannot be input x of bad.st of type INT; expected a whole number"),
        Case("trace", "BOOL output column holding 2", "verify", expect, _counter_trace([1, 2], [1, 8], [1, 2]), "error",
             "cannot be the recorded output flag of type BOOL; expected 0 or 1"),
        Case("trace", "DINT output that differs", "verify", expect, _counter_trace([1, 2], [1, 9], [1, 1]), "refused",
             "NOT bit-exact"),
        Case("trace", "integer overflow in the block", "verify", expect, _counter_trace([1, 2000], [1, 0], [1, 1]),
             "refused", "NOT"),
    ]


def _review_cases() -> list[Case]:
    """Issue 27: a block that is not its model's fails verify (exit 1) on every path."""
    golden = ("verify", "bad.scl", "--model", "bad.json", "--data", "golden_twin.csv")
    return [
        Case("ST file", "a table entry no fault case reaches, edited", "verify --faults", (*golden, "--faults"),
             _golden_pair("bayes", lambda t: table_entry_edited(t, "tab_Pred", 6, "99.5")), "refused",
             "NOT bit-exact: bad.scl holds constants that differ from the model"),
        Case("ST file", "an index stride edited: c_K_1 sends the index outside tab_Pred", "verify", golden,
             _golden_pair("bayes", lambda t: t.replace("c_K_1 : Int := 8;", "c_K_1 : Int := 9;")), "refused",
             "bad.scl:370:22: index 69 outside tab_Pred[0..63] at cycle 388"),
        Case("ST file", "a declared INT constant replaced by a literal where it is read", "verify", golden,
             _golden_pair("bayes", lambda t: t.replace("+ #c_OneCall", "+ 2")), "refused",
             "c_OneCall: declared but never read by the statements"),
    ]


def _xml_edit(edit: Callable[[str], str]):
    def prepare(folder: Path) -> None:
        (folder / "bad.xml").write_text(edit((folder / "block.xml").read_text()))
    return prepare


def _one_pou_more(text: str) -> str:
    start, end = text.index("      <pou "), text.index("      </pou>") + len("      </pou>\n")
    return text[:end] + text[start:end].replace('name="ThermalComp"', 'name="Other"', 1) + text[end:]


def _cut(text: str, first: str, last: str, instead: str = "") -> str:
    start, end = text.index(first), text.index(last) + len(last)
    return text[:start] + instead + text[end:]


def _plcopen_cases() -> list[Case]:
    """Issue 28 item 9: the PLCopen XML of generate --format plcopen (block.xml), read by verify and diff."""
    verify = ("verify", "bad.xml", "--model", "mlr.json", "--data", "good.csv")
    diff = ("diff", "block.scl", "bad.xml")
    vendor = ('<addData><data name="http://www.3s-software.com/plcopenxml/method" handleUnknown="implementation">'
              '<Method name="FB_init"/></data></addData>\n        <documentation>')
    faults = [
        ("not XML (ST text named .xml)", lambda t: "FUNCTION_BLOCK ThermalComp\nEND_FUNCTION_BLOCK\n",
         "bad.xml:1:1: not XML (it starts with 'FUNCTION_BLOCK Therm', not '<?xml' or '<project')"),
        ("XML cut short", lambda t: t[:t.index("<", 4000)], "not well-formed XML (no element found)"),
        ("a DOCTYPE declaring entities", lambda t: t.replace(
            "<project ", '<!DOCTYPE project [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;&a;&a;">]>\n<project ', 1),
         "a DOCTYPE is refused (entity declarations could expand without bound"),
        ("XML that is not PLCopen", lambda t: '<?xml version="1.0"?>\n<svg xmlns="http://www.w3.org/2000/svg"/>\n',
         "bad.xml:2:1: the root element is <svg> in http://www.w3.org/2000/svg; expected PLCopen TC6 XML 2.01"),
        ("two POUs", _one_pou_more, "a second POU 'Other' after 'ThermalComp'; expected one function block per file"),
        ("no body", lambda t: _cut(t, "        <body>", "        </body>\n"),
         "bad.xml:14:7: POU 'ThermalComp' has no <body>; expected its ST body"),
        ("a body in FBD", lambda t: _cut(t, "          <ST>", "          </ST>\n", "          <FBD/>\n"),
         "the body of POU 'ThermalComp' is in FBD; the verifier reads ST bodies only"),
        ("an LREAL variable", lambda t: t.replace("<type><REAL/></type>", "<type><LREAL/></type>", 1),
         "bad.xml:18:21: variable 'T_motor': type LREAL is not supported (REAL, BOOL, INT, DINT and arrays of them are)"),
        ("a derived type", lambda t: t.replace("<type><REAL/></type>", '<type><derived name="TEMP_T"/></type>', 1),
         "variable 'T_motor': type 'TEMP_T' (a derived type) is not supported"),
        ("an in-out variable", lambda t: t.replace("<inputVars>", "<inOutVars>", 1).replace("</inputVars>", "</inOutVars>", 1),
         "bad.xml:16:11: <inOutVars> (VAR_IN_OUT section) is not supported"),
        ("a CODESYS method in the POU", lambda t: t.replace("<documentation><xhtml:p>Thermal", vendor + "<xhtml:p>Thermal", 1),
         "vendor data 'http://www.3s-software.com/plcopenxml/method' in POU 'ThermalComp'"),
        ("declarations in the ST body", lambda t: t.replace("    ENO := Enable;", "    VAR x : REAL; END_VAR\n    ENO := Enable;", 1),
         "VAR in the body (statements only: the XML's <interface> declares the variables) is not supported"),
        ("a start value ST does not take", lambda t: t.replace('value="30"', 'value="16#1E"', 1),
         "variable 'c_SettleCalls': '16#1E' is not a start value an ST declaration takes"),
    ]
    cases = []
    for fault, edit, message in faults:
        cases.append(Case("PLCopen XML", fault, "verify", verify, _xml_edit(edit), "error", message))
    for fault, edit, message in faults[4:5] + faults[7:8]:
        cases.append(Case("PLCopen XML", fault, "diff", diff, _xml_edit(edit), "error", message))
    coefficient = re.compile(r'(<variable name="c_beta_1">\s*<type><REAL/></type>\s*<initialValue><simpleValue value=")'
                             r'[^"]+')
    cases += [
        Case("PLCopen XML", "the XML generate wrote", "verify", ("verify", "block.xml", "--model", "mlr.json", "--data",
             "good.csv"), lambda f: None, "accepted", "bit-exact: block.xml reproduces the float32 reference"),
        Case("PLCopen XML", "a coefficient edited in the XML", "verify", verify,
             _xml_edit(lambda t: coefficient.sub(r"\g<1>10.5", t, 1)), "refused",
             "NOT bit-exact: bad.xml differs from the float32 reference of mlr.json"),
    ]
    return cases


def _files(texts: dict[str, Callable[[str], str]]):
    """Write each file (a path relative to the case's folder) with a text made from good.csv's."""
    def prepare(folder: Path) -> None:
        good = good_csv(folder)
        for name, make in texts.items():
            path = folder / name
            path.parent.mkdir(exist_ok=True)
            path.write_text(make(good))
    return prepare


def _coarser(text: str) -> str:
    """The recording at twice the sample period (every other row)."""
    lines = text.splitlines()
    return "\n".join([lines[0], *lines[1::2]]) + "\n"


def _campaign_cases() -> list[Case]:
    """Runs tables, folders of runs, grouped folds and a campaign's verify (issue 37)."""
    campaign = ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "-o", "out.json")
    run_b = _other_run  # another run: not a copy
    return [
        Case("campaign", "runs table without a 'file' column", "fit", (*campaign, "--runs", "runs.csv", "--folds", "2"),
             _files({"runs.csv": lambda _: "name,hall\ngood.csv,cool\n"}), "error", "runs.csv:1: no 'file' column"),
        Case("campaign", "runs table lists a run twice", "fit", (*campaign, "--runs", "runs.csv", "--folds", "2"),
             _files({"runs.csv": lambda _: "file,hall\ngood.csv,cool\ngood.csv,warm\n"}), "error",
             "runs.csv:3: good.csv is listed twice (first on line 2)"),
        Case("campaign", "runs table row of another width", "fit", (*campaign, "--runs", "runs.csv", "--folds", "2"),
             _files({"runs.csv": lambda _: "file,hall\ngood.csv,cool,extra\n"}), "error",
             "runs.csv:2: 3 fields, expected 2 as in the header"),
        Case("campaign", "runs table names a file that is not there", "fit",
             (*campaign, "--runs", "runs.csv", "--folds", "2"),
             _files({"runs.csv": lambda _: "file,hall\ngood.csv,cool\ngone.csv,warm\n"}), "error", "gone.csv: cannot read"),
        Case("campaign", "--group-by a column the runs table lacks", "fit",
             (*campaign, "--runs", "runs.csv", "--group-by", "colour"),
             _files({"runs.csv": lambda _: "file,hall\ngood.csv,cool\nb.csv,warm\n", "b.csv": run_b}), "error",
             "--group-by colour: not a column of the runs table"),
        Case("campaign", "--group-by with every run in one group", "fit",
             (*campaign, "--runs", "runs.csv", "--group-by", "hall"),
             _files({"runs.csv": lambda _: "file,hall\ngood.csv,cool\nb.csv,cool\n", "b.csv": run_b}), "error",
             "every run is in the one group 'cool'"),
        Case("campaign", "--group-by without a runs table", "fit", (*campaign, "--data", "good.csv", "--group-by", "hall"),
             lambda f: None, "error", "--group-by hall: not a column of the runs table"),
        Case("campaign", "a run at another sample period", "fit",
             (*campaign, "--data", "good.csv", "--data", "coarse.csv", "--folds", "2"),
             _files({"coarse.csv": _coarser}), "error", "coarse.csv: sampled every 20 s, but good.csv every 10 s"),
        Case("campaign", "more folds than runs", "fit", (*campaign, "--data", "good.csv", "--data", "b.csv", "--folds", "3"),
             _files({"b.csv": run_b}), "error", "--folds 3: with 2 runs expected 2 to 2 folds"),
        Case("campaign", "a run that is a copy of another", "fit",
             (*campaign, "--data", "good.csv", "--data", "copy.csv", "--folds", "2"),
             _files({"copy.csv": lambda text: text}), "error", "copy.csv: the same recording as good.csv"),
        Case("campaign", "--data a folder with no recordings", "fit", (*campaign, "--data", "empty", "--folds", "2"),
             lambda f: (f / "empty").mkdir(), "error", "empty: a folder with no recordings in it"),
        Case("campaign", "--data and --runs together", "fit",
             (*campaign, "--data", "good.csv", "--runs", "runs.csv", "--folds", "2"),
             _files({"runs.csv": lambda _: "file\ngood.csv\n"}), "error", "one of the two"),
        Case("campaign", "an empty cell in a temperature column", "fit", (*FIT, "bad.csv"),
             with_text("bad.csv", lambda t: _cell(t, 3, "T_motor", "")), "error",
             "column 'T_motor': expected a number, found ''"),
        Case("campaign", "a target never measured in a run", "fit", (*FIT, "bad.csv"),
             with_text("bad.csv", lambda t: "\n".join(
                 [line if k == 0 else ",".join("" if c == 8 else cell for c, cell in enumerate(line.split(",")))
                  for k, line in enumerate(t.splitlines())]) + "\n"), "error",
             "the target 'E_z_um' is measured on 0 of the 200 training rows"),
        Case("campaign", "verify a campaign with --json", "verify",
             ("verify", "block.scl", "--model", "mlr.json", "--data", "good.csv", "--data", "b.csv", "--json", "-"),
             _files({"b.csv": run_b}), "error", "--json, --faults and --outputs take one recording"),
        Case("campaign", "twin --runs into a folder with files", "twin",
             ("twin", "--runs", "2", "--hours", "1", "-o", "full"), _files({"full/x.txt": lambda _: "x"}), "error",
             "with --runs, a new or empty folder"),
        Case("campaign", "fit -o onto a run of the folder", "fit",
             (*campaign[:-2], "-o", "runs/b.csv", "--data", "runs", "--folds", "2", "--force"),
             _files({"runs/a.csv": lambda t: t, "runs/b.csv": run_b}), "error", "is also an input of this command"),
        Case("campaign", "--report onto the model file", "fit",
             (*campaign, "--data", "good.csv", "--data", "b.csv", "--folds", "2", "--report", "out.json"),
             _files({"b.csv": run_b}), "error", "--report out.json: is also the -o output"),
        Case("campaign", "--runs names a folder", "fit", (*campaign, "--runs", "runs", "--folds", "2"),
             _files({"runs/a.csv": lambda t: t}), "error", "--runs runs: a folder; give its runs table"),
        Case("campaign", "a runs table given as --data", "fit", (*campaign, "--data", "runs.csv", "--train-rows", "200"),
             _files({"runs.csv": lambda _: "file,hall\ngood.csv,cool\n"}), "error", "a runs table? give it as --runs"),
        Case("campaign", "a runs table row of empty fields", "fit", (*campaign, "--runs", "runs.csv", "--folds", "2"),
             _files({"runs.csv": lambda _: "file,hall\ngood.csv,cool\n,\n"}), "error",
             "runs.csv:3: column 'file' is empty"),
        Case("campaign", "twin --effect-runs without --effect", "twin",
             ("twin", "--runs", "2", "--hours", "1", "--effect-runs", "1", "-o", "c"), lambda f: None, "error",
             "--effect-runs says in which runs the --effect hides"),
        Case("campaign", "twin --probe-minutes off the call grid", "twin",
             ("twin", "--runs", "2", "--hours", "2", "--dt", "60", "--probe-minutes", "1.5", "-o", "c"), lambda f: None,
             "error", "a whole number of --dt 60 s periods"),
        Case("campaign", "twin --runs with --ambient-start", "twin",
             ("twin", "--runs", "2", "--hours", "1", "--ambient-start", "30", "-o", "c"), lambda f: None, "error",
             "--ambient-start and --ambient-swing: not with --runs"),
        Case("campaign", "twin --probe-minutes without --runs", "twin",
             ("twin", "--hours", "1", "--probe-minutes", "30", "-o", "t.csv"), lambda f: None, "error",
             "--probe-every (--probe-minutes), --effect-runs and --ambient-levels describe a campaign"),
        Case("campaign", "twin --ambient-levels without --runs", "twin",
             ("twin", "--hours", "1", "--ambient-levels", "14,33", "-o", "t.csv"), lambda f: None, "error",
             "--ambient-levels describe a campaign: give --runs N"),
        Case("campaign", "twin --ambient-levels with a word", "twin",
             ("twin", "--runs", "2", "--hours", "1", "--ambient-levels", "14,hot", "-o", "c"), lambda f: None, "error",
             "expected hall air levels C,C,... in degC from -40 to 60, found '14,hot'"),
        Case("campaign", "twin --ambient-levels more than the runs", "twin",
             ("twin", "--runs", "2", "--hours", "1", "--ambient-levels", "14,20,26", "-o", "c"), lambda f: None, "error",
             "--ambient-levels gives 3 levels for --runs 2: each level needs a run"),
        Case("campaign", "twin --ambient-levels beyond a hall's air", "twin",
             ("twin", "--runs", "2", "--hours", "1", "--ambient-levels", "14,1e9", "-o", "c"), lambda f: None, "error",
             "expected hall air levels C,C,... in degC from -40 to 60, found '14,1e9'"),
    ]


def _read_two_ways_cases() -> list[Case]:
    """Issue 38: input one path reads and another skips is refused where it is, never read two ways."""
    verify = ("verify", "bad.xml", "--model", "mlr.json", "--data", "good.csv")
    diff = ("diff", "block.scl", "bad.xml")
    after_body = lambda t: t.replace("]]></xhtml:p>", "]]></xhtml:p>\nE_z_um := 250.0;", 1)
    fbd_after = lambda t: t.replace("          </ST>\n", "          </ST>\n          <FBD/>\n", 1)
    return [
        Case("PLCopen XML", "a statement after </xhtml:p> in <ST>", "verify", verify, _xml_edit(after_body), "error",
             "'E_z_um := 250.0;' in <ST> is not read by the verifier"),
        Case("PLCopen XML", "a statement after </xhtml:p> in <ST>", "diff", diff, _xml_edit(after_body), "error",
             "'E_z_um := 250.0;' in <ST> is not read by the verifier"),
        Case("PLCopen XML", "<FBD> after <ST> in the body", "verify", verify, _xml_edit(fbd_after), "error",
             "a second body language <FBD> after <ST> in POU 'ThermalComp'"),
        Case("PLCopen XML", "text between interface sections", "verify", verify,
             _xml_edit(lambda t: t.replace("</inputVars>", "</inputVars> x := 1;", 1)), "error",
             "'x := 1;' in <interface> is not read by the verifier"),
        Case("CSV", "7.500 (a thousands point) in a decimal-comma file", "fit", (*FIT, "bad.csv"),
             with_text("bad.csv", lambda t: _cell(_german(t), 100, "n_rpm", "7.500", ";")), "error",
             "bad.csv:101:2: column 'n_rpm': '7.500' has a '.' in a file read with decimal commas"),
        Case("CSV", "7.500 (a thousands point) in a decimal-comma file", "verify", (*VERIFY, "bad.csv"),
             with_text("bad.csv", lambda t: _cell(_german(t), 100, "n_rpm", "7.500", ";")), "error",
             "bad.csv:101:2: column 'n_rpm': '7.500' has a '.' in a file read with decimal commas"),
        Case("CSV", "a cell 21.000,02016 quoted as written", "fit", (*FIT, "bad.csv"),
             with_text("bad.csv", lambda t: _cell(_german(t), 7, "T_env", "21.000,02016", ";")), "error",
             "column 'T_env': '21.000,02016' has a '.'"),
        Case("CSV", "--decimal , on a ';' file of decimal points", "fit", (*FIT, "bad.csv", "--decimal", ","),
             with_text("bad.csv", lambda t: t.replace(",", ";")), "error",
             "bad.csv:2:4: column 'T_env'"),
        Case("CSV", "';' and decimal points with --decimal .", "fit", (*FIT, "bad.csv", "--decimal", "."),
             with_text("bad.csv", lambda t: t.replace(",", ";")), "accepted", "wrote out.json"),
        *[Case("options", f"--model {kind}: --temps {fault}", "fit",
               ("fit", "--model", kind, "--target", "E_z_um", "--temps", temps, "--train-rows", "200", "-o", "out.json",
                "--data", "good.csv"), lambda f: None, "error", message)
          for kind in ("mlr", "auto") for fault, temps, message in (
              ("with a typo", "T_motor,T_typo", "good.csv: no column 'T_typo'"),
              ("holding the target", "T_motor,E_z_um", "--temps E_z_um: the column is the target (--target)"),
              ("holding time_s", "T_motor,time_s", "--temps time_s: the column is the time column (--time)"),
              ("naming a sensor twice", "T_motor,T_bearing,T_motor", "--temps: column 'T_motor' is given twice"))],
        Case("options", "--temp-range -40,150 (the default as --help prints it)", "generate",
             ("generate", "mlr.json", "--temp-range", "-40,150", "-o", "out.scl"), lambda f: None, "accepted",
             "wrote out.scl"),
        Case("options", "--temp-range -40 (one value)", "generate",
             ("generate", "mlr.json", "--temp-range", "-40", "-o", "out.scl"), lambda f: None, "error",
             "expected LOW,HIGH (two numbers), found '-40'"),
        Case("outputs", "-o new.scl/ (a trailing separator)", "generate", ("generate", "mlr.json", "-o", "new.scl/"),
             lambda f: None, "error", "new.scl/: ends in a separator, so it names a folder"),
        Case("model file", "held-out rows 10^12", "generate", ("generate", "bad.json", "-o", "out.scl"),
             _model_edit(lambda d: d["metrics"]["held_out"].update(rows=10 ** 12)), "error",
             "field 'metrics.held_out.rows': 1000000000000; expected a whole number of rows from 0 to"),
        Case("ST file", "a comment nested in a comment (CODESYS nests them)", "verify",
             ("verify", "bad.scl", "--model", "mlr.json", "--data", "good.csv"),
             _block_edit(lambda t: t.replace("    ENO := #Enable;", "    (* n (* x *) // *) ENO := FALSE;\n    ENO := #Enable;", 1)),
             "error", "(* inside a (* comment: compilers disagree whether comments nest"),
        Case("ST file", "a lone carriage return ending a // comment", "verify",
             ("verify", "bad.scl", "--model", "mlr.json", "--data", "good.csv"),
             _block_edit(lambda t: t.replace("    ENO := #Enable;", "    // note\rENO := FALSE;\n    ENO := #Enable;", 1)),
             "error", "a carriage return without a line feed (U+000D)"),
        Case("PLCopen XML", "encoding=\"UTF-7\" in a UTF-8 file", "verify", verify,
             _xml_edit(lambda t: t.replace('encoding="utf-8"', 'encoding="UTF-7"', 1)), "error",
             "bad.xml:1:31: the XML declaration says encoding='UTF-7'"),
        Case("PLCopen XML", "a second start value", "verify", verify,
             _xml_edit(lambda t: t.replace('<simpleValue value="30"/></initialValue>', '<simpleValue value="30"/>'
                                           '</initialValue><initialValue><simpleValue value="1"/></initialValue>', 1)),
             "error", "a second <initialValue> in variable 'c_SettleCalls'"),
        Case("options", "--data twice for diff", "diff", ("diff", "block.scl", "block.scl", "--data", "good.csv", "--data",
             "good.csv"), lambda f: None, "error", "--data given twice (good.csv and good.csv); this option takes one value"),
        Case("CSV", "Enable and enable beside each other", "verify", (*VERIFY, "bad.csv"),
             with_text("bad.csv", lambda t: "\n".join([t.splitlines()[0] + ",Enable,enable"]
                                                      + [r + ",1,0" for r in t.splitlines()[1:]]) + "\n"),
             "error", "columns Enable, enable could each drive the block input Enable"),
        Case("ST file", "an {IF} conditional-compilation pragma", "verify",
             ("verify", "bad.scl", "--model", "mlr.json", "--data", "good.csv"),
             _block_edit(lambda t: t.replace("    ENO := #Enable;", "    {IF defined(never)}\n    ENO := FALSE;\n    {END_IF}"
                                               "\n    ENO := #Enable;", 1)),
             "error", "a conditional-compilation pragma"),
        Case("ST file", "a REAL literal that rounds differently through a double", "verify",
             ("verify", "bad.scl", "--model", "mlr.json", "--data", "good.csv"),
             _block_edit(lambda t: re.sub(r"(c_beta_1 : Real := )[^;]+;", r"\g<1>9.608996868133544921874999999999;", t,
                                          count=1, flags=re.IGNORECASE)),
             "error", "REAL 9.608996868133544921874999999999 rounds to"),
        Case("CSV", "a no-break space before a number", "verify", (*VERIFY, "bad.csv"),
             with_text("bad.csv", lambda t: _cell(t, 100, "T_motor", "\u00a025.5")), "error",
             "bad.csv:101:5: column 'T_motor': expected a number, found '\\xa025.5'"),
        Case("CSV", "a column name with a zero-width space", "verify", (*VERIFY, "bad.csv"),
             with_text("bad.csv", lambda t: "\n".join([t.splitlines()[0] + ",Reset\u200b"]
                                                      + [r + ",0" for r in t.splitlines()[1:]]) + "\n"),
             "error", "holds an invisible character (U+200B)"),
        Case("stdin", "--data - twice", "verify", ("verify", "block.scl", "--model", "mlr.json", "--data", "-", "--data", "-"),
             lambda f: None, "error", "--data -: standard input can be read once; give the other runs as files"),
        Case("PLCopen XML", "an XML comment splitting the body", "verify", verify,
             _xml_edit(lambda t: t.replace("    ENO := Enable;", "]]><!-- c --><![CDATA[    ENO := Enable;", 1)),
             "error", "a comment in <xhtml:p> is not read by the verifier"),
    ]


_SERVED: dict[int, object] = {}


def _serving(port: int, answer: bytes | None):
    """A prepare that starts, once per process, a server on 127.0.0.1:`port` that accepts every connection and
    never answers (`answer` None) or answers `answer` over and over: a store or scheduler gone wrong."""
    import socket
    import threading

    def talk(connection) -> None:
        try:
            while answer is not None:
                connection.sendall(answer)
        except OSError:
            pass

    def serve(listener) -> None:
        while True:
            connection, _ = listener.accept()
            _SERVED.setdefault("connections", []).append(connection)
            threading.Thread(target=talk, args=(connection,), daemon=True).start()

    def prepare(folder: Path) -> None:
        (folder / "m.csv").write_text("block,data,model\nblock.scl,good.csv,mlr.json\n")
        if port not in _SERVED:
            listener = socket.socket()
            listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            listener.bind(("127.0.0.1", port))
            listener.listen(64)
            _SERVED[port] = listener
            threading.Thread(target=serve, args=(listener,), daemon=True).start()
    return prepare


def _hostile_review_cases() -> list[Case]:
    """Issue 48: outputs inside outputs, empty names, NUL bytes, a broken link, --decimal in a campaign, a store
    and a scheduler that never answer or answer garbage (fixed ports: the table shows the command)."""
    campaign = ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "-o", "out.json")
    run_b = _other_run
    two_runs = ("--data", "good.csv", "--data", "b.csv", "--folds", "2")

    def broken_link(folder: Path) -> None:
        (folder / "runs").mkdir()
        (folder / "runs" / "a.csv").write_text(good_csv(folder))
        (folder / "runs" / "b.csv").symlink_to("gone.csv")

    nul_table = _files({"runs.csv": lambda _: "file\ngood.csv\nb\0.csv\n"})
    nul_manifest = _files({"m.csv": lambda _: "block,data,model\nblock.scl,good\0.csv,mlr.json\n"})
    return [
        Case("output", "fit -o naming a file of its --report folder", "fit",
             (*campaign[:-2], "-o", "rep/run_002.png", *two_runs, "--report", "rep"), _files({"b.csv": run_b}), "error",
             "rep/run_002.png: is inside the --report folder rep, whose files are the report's; give -o a file "
             "outside it"),
        Case("output", "fit --json naming the report's index.html", "fit",
             (*campaign, *two_runs, "--report", "rep", "--json", "rep/index.html"), _files({"b.csv": run_b}), "error",
             "rep/index.html: is inside the --report folder rep"),
        Case("output", "fit --json onto its -o", "fit", (*campaign, *two_runs, "--json", "out.json"),
             _files({"b.csv": run_b}), "error", "out.json: named for both -o and --json"),
        Case("output", "--report around an input", "fit", (*campaign, "--data", "runs", "--folds", "2", "--report", "runs"),
             _files({"runs/a.csv": lambda t: t, "runs/b.csv": run_b}), "error",
             "--report runs: holds runs/a.csv, an input of this command"),
        Case("output", "--report an object-store URL", "fit", (*campaign, *two_runs, "--report", "s3://bucket/rep"),
             _files({"b.csv": run_b}), "error", "--report s3://bucket/rep: a report is written to a local folder"),
        Case("options", "--report ''", "fit", (*campaign, *two_runs, "--report", ""), _files({"b.csv": run_b}),
             "error", "argument --report: expected a folder for the report, found an empty name"),
        Case("options", "--data ''", "verify", ("verify", "block.scl", "--model", "mlr.json", "--data", ""),
             lambda f: None, "error", "argument --data: expected a recording (CSV, .npz or Parquet) or a folder of "
                                      "them, found an empty name"),
        Case("options", "--runs ''", "fit", (*campaign, "--runs", "", "--folds", "2"), lambda f: None, "error",
             "argument --runs: expected a runs table (CSV), found an empty name"),
        Case("options", "--group-by ''", "fit", (*campaign, "--data", "good.csv", "--group-by", ""), lambda f: None,
             "error", "argument --group-by: expected a column of the runs table, found an empty name"),
        Case("campaign", "a NUL byte in a runs table's file", "fit", (*campaign, "--runs", "runs.csv", "--folds", "2"),
             nul_table, "error", "runs.csv:3: column 'file': a NUL character in 'b\\x00.csv'"),
        Case("campaign", "a NUL byte in a runs table's file", "verify",
             ("verify", "block.scl", "--model", "mlr.json", "--runs", "runs.csv", "--jobs", "2"), nul_table, "error",
             "runs.csv:3: column 'file': a NUL character in 'b\\x00.csv'"),
        Case("manifest", "a NUL byte in a manifest's file", "verify", ("verify", "--manifest", "m.csv", "--jobs", "2"),
             nul_manifest, "error", "m.csv:2: column 'data': a NUL character in 'good\\x00.csv'"),
        Case("campaign", "a data folder holding a link to nothing", "fit", (*campaign, "--data", "runs", "--folds", "2"),
             broken_link, "error", "runs/b.csv: a symbolic link to gone.csv, which does not exist"),
        Case("campaign", "';' runs with decimal points, --decimal .", "verify",
             ("verify", "block.scl", "--model", "mlr.json", "--data", "a.csv", "--data", "b.csv", "--decimal", "."),
             _files({"a.csv": lambda t: t.replace(",", ";"), "b.csv": lambda t: run_b(t).replace(",", ";")}),
             "accepted", "campaign: block.scl against mlr.json on 2 runs"),
        Case("campaign", "twin --runs whose rows in all pass the cap", "twin",
             ("twin", "--runs", "10000", "--hours", "1000", "-o", "c"), lambda f: None, "error",
             "--runs 10000 of --hours 1000 at --dt 10 gives more than 50,000,000 rows in all"),
        Case("object store", "an S3 endpoint that accepts and never answers", "verify",
             ("verify", "block.scl", "--model", "mlr.json", "--data",
              "s3://plant/run.csv?endpoint_override=127.0.0.1:47391&scheme=http"), _serving(47391, None), "error",
             "cannot read: no answer from the store within 20 s"),
        Case("cluster", "--scheduler at a server that never answers", "verify",
             ("verify", "--manifest", "m.csv", "--scheduler", "tcp://127.0.0.1:47392"), _serving(47392, None), "error",
             "--scheduler tcp://127.0.0.1:47392: cannot reach a Dask scheduler there (no answer within 20 s)"),
        Case("cluster", "--scheduler at a server that answers garbage", "verify",
             ("verify", "--manifest", "m.csv", "--scheduler", "tcp://127.0.0.1:47393"),
             _serving(47393, b"\xff\xfe garbage " * 64), "error",
             "cannot reach a Dask scheduler there (what answers there is not a Dask scheduler)"),
    ]


def _probing_cases() -> list[Case]:
    """Issue 49: the probe fusion's options where they cannot mean anything."""
    fit = ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "-o", "out.json", "--data",
           "good.csv")
    verify = ("verify", "block.scl", "--model", "mlr.json", "--data", "good.csv")
    return [
        Case("probing", "--probe on one recording with --folds", "fit", (*fit, "--folds", "3", "--probe"),
             lambda f: None, "error", "--probe on one recording chooses the fusion on its held-out part"),
        Case("probing", "--probe on a full-rate target without a schedule", "fit", (*fit, "--train-rows", "400",
             "--probe"), lambda f: None, "error", "is measured at every call, so the data holds no probing schedule"),
        Case("probing", "--probe-every without --probe", "fit", (*fit, "--train-rows", "400", "--probe-every", "30"),
             lambda f: None, "error", "--probe-every sets the probing schedule of a fused block; give --probe"),
        Case("probing", "--probe-every longer than the recording", "fit", (*fit, "--train-rows", "400", "--probe",
             "--probe-every", "100000"), lambda f: None, "error", "--probe: no probing falls in the runs"),
        Case("probing", "verify --probe-every on a static block", "verify", (*verify, "--probe-every", "30"),
             lambda f: None, "error", "--probe-every 30: the model has no probe fusion (fit it with --probe)"),
    ]


def _shifted_from(text: str, row: int, seconds: float) -> str:
    """Every time stamp from `row` on later by `seconds`: a gap in the logger's file."""
    lines = text.splitlines()
    for k in range(row, len(lines)):
        cells = lines[k].split(",")
        cells[0] = f"{float(cells[0]) + seconds:g}"
        lines[k] = ",".join(cells)
    return "\n".join(lines) + "\n"


def _resample_cases() -> list[Case]:
    """Issue 50: raw logger data taken onto the cycle, and the probings of a diff, where they cannot be."""
    fit = ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "--train-rows", "200",
           "-o", "out.json", "--data")
    verify = ("verify", "block.scl", "--model", "mlr.json", "--data", "good.csv")
    return [
        Case("resampling", "--resample under 1 ms", "fit", (*fit, "good.csv", "--resample", "0.0004"), lambda f: None,
             "error", "argument --resample: expected the block's cycle in seconds from 0.001 to 86400, found 0.0004"),
        Case("resampling", "--resample not a whole number of ms", "fit", (*fit, "good.csv", "--resample", "10.0005"),
             lambda f: None, "error", "expected a whole number of milliseconds (a PLC cycle is set in ms), found 10.0005"),
        Case("resampling", "a gap longer than 8 cycles", "fit", (*fit, "gap.csv", "--resample", "10"),
             with_text("gap.csv", lambda t: _shifted_from(t, 300, 500.0)), "error",
             "gap.csv:301: column 'time_s': no row for 510 s (from 2980 s to 3490 s); --resample 10 bridges at most 8 "
             "calls (80 s): cut the run there into two runs"),
        Case("resampling", "verify --resample other than the block's cycle", "verify", (*verify, "--resample", "20"),
             lambda f: None, "error", "--resample 20: the block runs every 10 s (sample_period_s of the model file); "
                                      "give --resample 10"),
        Case("resampling", "verify --resample with a PLC trace", "verify",
             ("verify", "block.scl", "--expect", "E_z_um", "--data", "good.csv", "--resample", "10"), lambda f: None,
             "error", "--resample takes raw data onto a model's cycle (--model); a PLC trace (--expect) is recorded"),
        Case("resampling", "model file: resample period other than its cycle", "verify",
             ("verify", "block.scl", "--model", "bad.json", "--data", "good.csv"),
             _model_edit(_set(["resample"], {"period_s": 20.0, "hold": []})), "error",
             "bad.json: field 'resample.period_s': 20 s, but the block's cycle (sample_period_s) is 10 s"),
        Case("resampling", "diff --probe-every without --probe-target", "diff",
             ("diff", "block.scl", "block.scl", "--data", "good.csv", "--probe-every", "30"), lambda f: None, "error",
             "--probe-every and --held-target say how --probe-target holds the probings; give --probe-target"),
        Case("resampling", "diff --probe-target without --data", "diff",
             ("diff", "block.scl", "block.scl", "--probe-target", "E_z_um"), lambda f: None, "error",
             "--probe-target replays probings on --data; give --data"),
    ]


def _parquet_copy(folder: Path) -> None:
    import pyarrow.csv
    import pyarrow.parquet
    (folder / "runs").mkdir()
    (folder / "runs" / "a.csv").write_text(good_csv(folder))
    (folder / "runs" / "b.csv").write_text(_cell(good_csv(folder), 5, "E_z_um", "0.125"))
    pyarrow.parquet.write_table(pyarrow.csv.read_csv(folder / "runs" / "a.csv"), folder / "runs" / "c.parquet")


def _fused(folder: Path) -> None:
    """fused.json (mlr with --probe) and its block fused.scl, fitted on good.csv."""
    thermoplc("fit", "--data", "good.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
              "--train-rows", "400", "--probe", "--probe-every", "30", "-o", "fused.json", cwd=folder)
    thermoplc("generate", "fused.json", "-o", "fused.scl", "--accept-unvalidated", cwd=folder)


def _control_column(name: str, value: str):
    """good.csv with a control column `name`, 0 (Enable: 1) but `value` on one row."""
    def make(text: str) -> str:
        lines = text.splitlines()
        rest = ["1" if name == "Enable" else "0"] * (len(lines) - 1)
        rest[40] = value
        return "\n".join([f"{lines[0]},{name}", *(f"{line},{cell}" for line, cell in zip(lines[1:], rest))]) + "\n"
    return make


def _unix_time(text: str) -> str:
    """The time column as a logger's Unix time stamps (2026-01-01 on)."""
    lines = text.splitlines()
    rows = [line.split(",") for line in lines[1:]]
    for cells in rows:
        cells[0] = f"{1767225600 + float(cells[0]):.1f}"
    return "\n".join([lines[0], *(",".join(cells) for cells in rows)]) + "\n"


def _inputs_stay_inputs_cases() -> list[Case]:
    """Issue 60: no output replaces a file the command read, a copy of a run in other bytes is no held-out run,
    control columns keep their rule through --resample, and the API's refusals have the command line's words."""
    fit = ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "-o", "out.json")
    fused = ("verify", "fused.scl", "--model", "fused.json", "--data", "ctl.csv", "--resample", "10")
    one_run = _files({"one/a.csv": lambda t: t, "one/runs.csv": lambda _: "file\na.csv\n"})
    return [
        Case("inputs", "verify --outputs onto the runs table it read", "verify",
             ("verify", "block.scl", "--model", "mlr.json", "--data", "one", "--outputs", "one/runs.csv", "--force"),
             one_run, "error", "one/runs.csv: is also an input of this command"),
        Case("inputs", "verify --json onto the --expect @FILE", "verify",
             ("verify", "block.scl", "--data", "good.csv", "--expect", "@exp.csv", "--json", "exp.csv", "--force"),
             _files({"exp.csv": lambda _: "E_z_um\n"}), "error", "exp.csv: is also an input of this command"),
        Case("inputs", "fit -o onto the --target @FILE", "fit",
             ("fit", "--model", "mlr", "--target", "@t.txt", "--temps", "T_motor", "--train-rows", "200", "--data",
              "good.csv", "-o", "t.txt", "--force"), _files({"t.txt": lambda _: "E_z_um\n"}), "error",
             "t.txt: is also an input of this command"),
        Case("inputs", "select-sensors -o onto the --candidates @FILE", "select-sensors",
             ("select-sensors", "--data", "good.csv", "--target", "E_z_um", "--candidates", "@c.txt", "-o", "c.txt",
              "--force"), _files({"c.txt": lambda _: "T_motor,T_bearing\n"}), "error",
             "c.txt: is also an input of this command"),
        Case("inputs", "diagnose --json onto the --temps @FILE", "diagnose",
             (*DIAGNOSE[:5], "--temps", "@d.txt", "--target", "E_z_um", "--data", "good.csv", "--json", "d.txt"),
             _files({"d.txt": lambda _: "T_motor\n"}), "error", "d.txt: is also an input of this command"),
        Case("inputs", "a run and its Parquet copy in one folder", "fit", (*fit, "--data", "runs", "--folds", "3"),
             _parquet_copy, "error", "runs/c.parquet: the same recording as runs/a.csv (the same columns and numbers "
                                     "in other bytes)"),
        Case("inputs", "a run and its CRLF copy", "fit",
             (*fit, "--data", "good.csv", "--data", "crlf.csv", "--folds", "2"),
             with_text("crlf.csv", lambda t: t.replace("\n", "\r\n").encode()), "error",
             "crlf.csv: the same recording as good.csv (the same columns and numbers in other bytes)"),
        *[Case("inputs", f"{name}={value} on a row between two calls under --resample", "verify",
               ("verify", "block.scl", "--model", "mlr.json", "--data", "ctl.csv", "--resample", "10"),
               _files({"ctl.csv": _control_column(name, value)}), "error",
               f"ctl.csv: line 42, column '{name}': {value} cannot be the {name} input (BOOL); expected 0 or 1")
          for name, value in (("Reset", "2"), ("Enable", "2"))],
        Case("inputs", "ProbeNew=0.5 on a row under --resample", "verify", fused,
             lambda f: (_fused(f), _files({"ctl.csv": lambda t: _control_column("ProbeNew", "0.5")(
                 _control_column("ProbeValue", "3.5")(t))})(f)), "error",
             "ctl.csv: line 42, column 'ProbeNew': 0.5 cannot be input ProbeNew of type BOOL; expected 0 or 1"),
        Case("inputs", "--resample onto fewer than 10 calls", "fit",
             (*fit, "--data", "good.csv", "--train-rows", "5", "--resample", "3600"), lambda f: None, "error",
             "good.csv: --resample 3600 takes its 721 rows onto 3 calls; at least 10 are needed: give a shorter cycle"),
        Case("inputs", "--train-until in a logger's Unix time", "fit",
             (*fit, "--data", "unix.csv", "--train-until", "1767229200"), with_text("unix.csv", _unix_time),
             "accepted", "wrote out.json"),
        Case("inputs", "--train-until before every row", "fit", (*fit, "--data", "good.csv", "--train-until", "-1e13"),
             lambda f: None, "error", "expected seconds from -1e+12 to 1e+12, found -1e13; or choose the training part "
                                      "with --train-rows N, or judge by cross-validation with --folds K"),
        Case("inputs", "--ambient for a kind that reads none", "fit",
             (*fit, "--data", "good.csv", "--train-rows", "400", "--ambient", "T_env"), lambda f: None, "error",
             "--ambient is read by --model kalman, piecewise or lumped only; --model mlr does not read it: leave it "
             "out or name it in --temps to read it as a temperature"),
        Case("inputs", "--speed for a kind that reads none", "fit",
             (*fit, "--data", "good.csv", "--train-rows", "400", "--speed", "n_rpm"), lambda f: None, "error",
             "--speed is read by --model kalman or lumped only"),
        Case("inputs", "verify --expect with --probe-every", "verify",
             ("verify", "block.scl", "--expect", "E_z_um", "--data", "good.csv", "--probe-every", "30"), lambda f: None,
             "error", "--probe-every makes up the probings of a replay against a model; a PLC trace (--expect) holds "
                      "the probings the PLC saw"),
        Case("inputs", "diff of fused blocks without their probings", "diff",
             ("diff", "fused.scl", "fused.scl", "--data", "good.csv"), _fused, "error",
             "no column 'ProbeValue' for input ProbeValue of fused.scl; a fused block replays its probings from "
             "columns ProbeValue and ProbeNew, from its target with --probe-target COLUMN, or map them with --inputs"),
        Case("inputs", "a probed target with one probing", "fit", (*fit, "--data", "one.csv", "--train-rows", "400"),
             with_text("one.csv", lambda t: "\n".join(
                 [line if k in (0, 100) else ",".join("" if c == 8 else cell for c, cell in enumerate(line.split(",")))
                  for k, line in enumerate(t.splitlines())]) + "\n"), "error",
             "one.csv: the target 'E_z_um' is measured on 1 of the 400 training rows (an empty cell is no measurement; "
             "with --held-target only a change is one)"),
        Case("inputs", "diagnose --held-target on a target that never changes", "diagnose",
             (*DIAGNOSE, "flat.csv", "--held-target"), with_text("flat.csv", lambda t: "\n".join(
                 [line if k == 0 else ",".join("5.0" if c == 8 else cell for c, cell in enumerate(line.split(",")))
                  for k, line in enumerate(t.splitlines())]) + "\n"), "error",
             "flat.csv: column 'E_z_um': measured 1 time(s) in the training part"),
        Case("inputs", "twin --logger at a 0.5 s cycle, then fit", "fit",
             ("fit", "--data", "lg.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor", "--train-rows",
              "400", "--resample", "0.5", "-o", "out.json"),
             lambda f: thermoplc("twin", "--hours", "0.5", "--dt", "0.5", "--logger", "-o", "lg.csv", cwd=f),
             "accepted", "wrote out.json"),
    ]


def _intercept_one_ulp_up(text: str) -> str:
    """The block with its intercept one ULP up, as the printer writes a REAL."""
    import numpy as np
    from thermoplc.generator.literals import real_literal
    old = re.search(r"c_beta0 : Real := ([^;]+);", text).group(1)
    new = real_literal(float(np.nextafter(np.float32(old), np.float32(np.inf))))
    return text.replace(f"c_beta0 : Real := {old};", f"c_beta0 : Real := {new};")


def _testbench_cases() -> list[Case]:
    """Issue 64: the test bench's window, options and output folder; a block that fails its own bench."""
    bench = ("testbench", "block.scl", "--model", "mlr.json", "--data", "good.csv", "-o", "bench")
    shown = "testbench"

    def existing(folder: Path) -> None:
        (folder / "bench").mkdir()
        (folder / "bench" / "ThermalComp_TB.scl").write_text("my own bench\n")

    def named_like_the_bench(folder: Path) -> None:
        (folder / "ThermalComp_TB.scl").write_text((folder / "block.scl").read_text())
    return [
        Case("test bench", "--calls beyond the rows", shown, (*bench, "--calls", "5000"), lambda f: None, "error",
             "--calls 5000: good.csv has 721 rows from row 1"),
        Case("test bench", "--from beyond the rows", shown, (*bench, "--from", "722"), lambda f: None, "error",
             "--from 722: good.csv has rows 1 to 721"),
        Case("test bench", "--calls 0", shown, (*bench, "--calls", "0"), lambda f: None, "error",
             "--calls: expected calls from 1 to 32,767, found 0"),
        Case("test bench", "--tolerance-um nan", shown, (*bench, "--tolerance-um", "nan"), lambda f: None, "error",
             "--tolerance-um: expected"),
        Case("test bench", "--rows-per-cycle 0", shown, (*bench, "--rows-per-cycle", "0"), lambda f: None, "error",
             "--rows-per-cycle: expected"),
        Case("test bench", "-o the recording", shown, (*bench[:-1], "good.csv"), lambda f: None, "error",
             "-o good.csv: good.csv is not a folder"),
        Case("test bench", "the bench file exists", shown, bench, existing, "error",
             "ThermalComp_TB.scl: exists; refusing to replace it"),
        Case("test bench", "the bench would replace the block read, with --force", shown,
             ("testbench", "ThermalComp_TB.scl", "--model", "mlr.json", "--data", "good.csv", "-o", ".", "--force"),
             named_like_the_bench, "error", "ThermalComp_TB.scl: is also an input of this command"),
        Case("test bench", "a block one ULP off the model", shown,
             ("testbench", "bad.scl", "--model", "mlr.json", "--data", "good.csv", "-o", "bench"),
             _block_edit(_intercept_one_ulp_up), "refused", "Mismatches = "),
        Case("test bench", "a window of the recording", shown, (*bench, "--calls", "100", "--from", "301"),
             lambda f: None, "accepted", "100 calls, rows 301 to 400 of good.csv's 721"),
    ]


CASES = [*_csv_cases(), *_model_cases(), *_st_cases(), *_injection_cases(), *_output_cases(), *_option_cases(),
         *_bounded_cases(), *_schema_cases(), *_nesting_cases(), *_data_file_cases(), *_verify_cases(),
         *_review_cases(), *_plcopen_cases(), *_campaign_cases(),
         *_read_two_ways_cases(), *_hostile_review_cases(), *_probing_cases(), *_resample_cases(),
         *_inputs_stay_inputs_cases(), *_testbench_cases()]


def setup_folder(folder: Path) -> None:
    """good.csv (2 h twin), mlr.json fitted on it, block.scl generated from it, and block.xml, its
    PLCopen XML."""
    (folder / "good.csv").write_text(write_table(simulate(2, seed=4)))
    thermoplc("fit", "--data", "good.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
              "--train-rows", "200", "-o", "mlr.json", cwd=folder, check=None)
    thermoplc("generate", "mlr.json", "-o", "block.scl", cwd=folder, check=None)
    thermoplc("generate", "mlr.json", "--dialect", "iec", "--format", "plcopen", "-o", "block.xml", cwd=folder, check=None)


def outcome(result: subprocess.CompletedProcess) -> str:
    """What the user sees: the error line, or the first line of the output."""
    if result.returncode == 2:
        return result.stderr.strip().splitlines()[-1] if result.stderr.strip() else "(no message)"
    lines = result.stdout.strip().splitlines()
    return lines[0] if lines else ""


def table_markdown(rows: list[tuple[Case, subprocess.CompletedProcess]]) -> str:
    out = ["| input | fault | command | exit | what the user sees |", "| --- | --- | --- | ---: | --- |"]
    for case, result in rows:
        seen = outcome(result).replace("|", "\\|")
        out.append(f"| {case.category} | {case.fault} | `{case.command}` | {result.returncode} | {seen} |")
    return "\n".join(out) + "\n"
