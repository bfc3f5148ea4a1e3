"""Issue 63 item 1: FL_THERMAL written as data loggers export it (date-times, a units row, dotted dates with
decimal commas, slashed dates, a daylight-saving change) fits, generates and verifies to the model of the
seconds file, bit for bit where the times are the same, or is refused naming the line and what to do."""
import json
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from tests.cli_runner import thermoplc
from thermoplc.base.errors import UserError
from thermoplc.base.identifiers import block_identifier
from thermoplc.recordings.reading import Reading, time_format_problem
from thermoplc.recordings.table import read_table
from thermoplc.recordings.timestamps import seconds_since_first
from thermoplc import api

FL_THERMAL = Path(api.__file__).parent / "data" / "fl_thermal" / "fl_thermal.csv"  # the copy the package ships
ROWS = 1500  # 6 h 15 min at 15 s
START = datetime(2024, 3, 1, 8, 0, 0)


@pytest.fixture(scope="module")
def fl():
    lines = FL_THERMAL.read_text().splitlines()
    header = lines[0].split(",")
    rows = [line.split(",") for line in lines[1:ROWS + 1]]
    return header, rows


def _export(path, header, rows, stamp, units=None, sep=",", comma=False, rename=lambda h: h):
    out = [sep.join(["timestamp", *map(rename, header[1:])])]
    if units is not None:
        out.append(sep.join(units))
    for r in rows:
        cells = [c.replace(".", ",") if comma else c for c in r[1:]]
        out.append(sep.join([stamp(float(r[0])), *cells]))
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    return path


def _fit(tmp_path, data, out, target="ch3_um", temps="t5_C,t4_C", time=("--time", "timestamp")):
    result = thermoplc("fit", "--data", data, *time, "--model", "mlr", "--target", target, "--temps", temps,
                       "--train-until", 15000, "-o", out, cwd=tmp_path)
    return json.loads((tmp_path / out).read_text()), result


def _bits(model):
    return {k: v["f32"] for k, v in model["coefficients"].items()}


def _refused(folder, name: str, text: str, time: str, message: str, reading: Reading = Reading()) -> None:
    """A file of `text` read with time column `time` is refused with `message` (a regular expression)."""
    (folder / name).write_text(text)
    with pytest.raises(UserError, match=message):
        read_table(folder / name, time, reading=reading)


def test_iso_dotted_and_units_row_exports_fit_generate_and_verify_to_the_seconds_files_model(tmp_path, fl):
    header, rows = fl
    (tmp_path / "seconds.csv").write_text("\n".join([",".join(header), *map(",".join, rows)]) + "\n")
    plain, _ = _fit(tmp_path, "seconds.csv", "seconds.json", time=())
    iso = _export(tmp_path / "iso.csv", header, rows, lambda s: (START + timedelta(seconds=s)).isoformat(sep=" "),
                  rename=lambda h: h.replace("_um", " [µm]").replace("_C", " [°C]"))
    model, result = _fit(tmp_path, iso.name, "iso.json", target="ch3 [µm]", temps="t5 [°C],t4 [°C]")
    assert _bits(model) == _bits(plain)
    assert [s["name"] for s in model["inputs"]] == [s["name"] for s in plain["inputs"]]  # t5_C, t4_C: units kept
    assert model["target"]["name"] == "ch3_um"
    assert "timestamp: date-times read as seconds since 2024-03-01 08:00:00" in result.stderr
    units = ["", "rpm", *("µm" if h.endswith("_um") else "°C" for h in header[2:])]
    dotted = _export(tmp_path / "dotted.csv", header, rows,
                     lambda s: (START + timedelta(seconds=s)).strftime("%d.%m.%Y %H:%M:%S"), units, ";", True)
    model, result = _fit(tmp_path, dotted.name, "dotted.json")
    assert _bits(model) == _bits(plain) and "units row read" in result.stderr
    thermoplc("generate", "dotted.json", "-o", "block.scl", "--accept-unvalidated", cwd=tmp_path)  # 4 h of training
    verdict = thermoplc("verify", "block.scl", "--model", "dotted.json", "--data", "dotted.csv", cwd=tmp_path).stdout
    assert verdict.startswith("bit-exact: block.scl reproduces the float32 reference of dotted.json")


def test_a_units_row_converts_millimetres_kelvin_and_minutes(tmp_path):
    path = tmp_path / "units.csv"
    path.write_text("time,T,E\nmin,K,mm\n0,293.15,0.0015\n0.5,294.15,0.0025\n")
    table = read_table(path, "time")
    np.testing.assert_array_equal(table.columns["time"], [0.0, 30.0])
    np.testing.assert_allclose(table.columns["T"], [20.0, 21.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(table.columns["E"], [1.5, 2.5], rtol=1e-15)
    assert table.lines.tolist() == [3, 4]


def test_times_with_their_utc_offset_cross_a_daylight_saving_change_and_without_it_are_refused(tmp_path):
    zone = lambda hours: timezone(timedelta(hours=hours))
    moments = [datetime(2024, 10, 27, 0, 59, 50, tzinfo=timezone.utc) + timedelta(seconds=10 * k) for k in range(4)]
    written = [m.astimezone(zone(2 if m.hour < 1 else 1)).isoformat() for m in moments]  # CEST -> CET at 01:00 UTC
    assert written[1].endswith("+01:00") and written[0].endswith("+02:00")
    path = tmp_path / "dst.csv"
    path.write_text("stamp,T1\n" + "".join(f"{w},{k}\n" for k, w in enumerate(written)))
    np.testing.assert_array_equal(read_table(path, "stamp").columns["stamp"], [0.0, 10.0, 20.0, 30.0])
    local = tmp_path / "local.csv"
    local.write_text("stamp,T1\n" + "".join(f"{w[:19]},{k}\n" for k, w in enumerate(written)))
    with pytest.raises(UserError, match=r"local.csv:3: column 'stamp': the clock goes back 3590 s .*UTC offset"):
        read_table(local, "stamp")


def test_slashed_dates_are_read_in_the_order_the_file_shows_and_refused_when_it_shows_none(tmp_path):
    path = tmp_path / "us.csv"
    path.write_text("time,T1\n03/12/2024 11:59:50 PM,1\n03/13/2024 12:00:00 AM,2\n")
    np.testing.assert_array_equal(read_table(path, "time").columns["time"], [0.0, 10.0])
    _refused(tmp_path, "both.csv", "time,T1\n03/01/2024 08:00:00,1\n03/01/2024 08:00:10,2\n", "time",
             r"both.csv:2: column 'time': '03/01/2024 08:00:00' reads as day first and "
             r"as month first .* give --time-format day-first or --time-format month-first")
    _refused(tmp_path, "mixed.csv", "time,T1\n13/01/2024 08:00:00,1\n01/13/2024 08:00:10,2\n", "time",
             r"mixed.csv:3: .*day first at line 2 and month first at line 3")


@pytest.mark.parametrize("cell", ["#N/A", "", "NaN", "---"])
def test_a_missing_cell_is_refused_by_line_and_column_saying_what_to_do(tmp_path, cell):
    path = tmp_path / "gap.csv"
    path.write_text(f"time_s,T1,T2\n0,1,2\n15,{cell},2\n")
    with pytest.raises(UserError, match=r"gap.csv:3:2: column 'T1': .*a missing value: give --gaps drop to drop its row, or --gaps hold:30s"):
        read_table(path)


def test_a_date_time_column_not_named_time_s_is_suggested_and_a_date_after_numbers_named(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("Timestamp,T1\n2024-03-01 08:00:00,1\n2024-03-01 08:00:15,2\n")
    with pytest.raises(UserError, match=r"no time column 'time_s' \(set it with --time: --time Timestamp\)"):
        read_table(path)
    _refused(tmp_path, "broken.csv", "t,T1\n2024-03-01 08:00:00,1\n15,2\n", "t",
             r"broken.csv:3: column 't': expected a date-time written as the first row's")


def test_units_in_column_names_keep_their_meaning_in_block_names():
    assert block_identifier("E_z [µm]", "target") == "E_z_um"  # not E_z_m, which reads as metres
    assert block_identifier("E_z [μm]", "target") == "E_z_um"  # Greek mu as well as the micro sign
    assert block_identifier("T_motor [°C]", "temperature") == "T_motor_C"


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, 10 ** 10), min_size=1, max_size=20, unique=True),
       st.sampled_from(["%Y-%m-%d %H:%M:%S.%f", "%Y-%m-%dT%H:%M:%S.%f", "%d.%m.%Y %H:%M:%S.%f"]))
def test_written_date_times_read_back_as_the_seconds_they_were_written_from(milliseconds, form):
    offsets = sorted(milliseconds)
    cells = [(START + timedelta(milliseconds=m)).strftime(form) for m in offsets]
    seconds, first = seconds_since_first(cells, list(range(2, len(cells) + 2)), "x.csv", "t")
    expected = [(m - offsets[0]) / 1000 for m in offsets]
    assert np.asarray(seconds).view(np.uint64).tolist() == np.asarray(expected).view(np.uint64).tolist()
    assert first == START + timedelta(milliseconds=offsets[0])


def test_units_are_converted_by_dimension_and_a_name_that_keeps_the_old_unit_is_refused(tmp_path):
    path = tmp_path / "dims.csv"
    path.write_text("time,F,count,E\ns,F,C,um\n0,1.5,3,0.5\n10,2.5,4,0.75\n")
    table = read_table(path, "time")  # F (a force?) and C (a count?) are not guessed to be temperatures
    assert table.columns["F"].tolist() == [1.5, 2.5] and table.columns["count"].tolist() == [3.0, 4.0]
    _refused(tmp_path, "m.csv", "time,T1\nm,°C\n0,20\n1,21\n", "time",
             r"m.csv:2:1: the units row says 'm' for the time column 'time': its unit 'm' "
             r"is not a time; expected s, ms, min, h or d")
    _refused(tmp_path, "named.csv", "time,ch3 [mm],t8_K\ns,mm,K\n0,0.001,293.15\n10,0.002,294.15\n", "time",
             r"named.csv:2:2: column 'ch3 \[mm\]' is converted from mm by the units row, "
             r"but its name says mm")


def test_edge_date_times_read_or_refused_with_the_reason(tmp_path):
    path = tmp_path / "hour.csv"
    path.write_text("t,T1\n2024-03-01 8:59:50,1\n2024-03-01 9:00:00,2\n")  # one-digit hours, as Excel writes them
    np.testing.assert_array_equal(read_table(path, "t").columns["t"], [0.0, 10.0])
    _refused(tmp_path, "same.csv", "t,T1\n2024-03-01T08:00:00Z,1\n2024-03-01T08:00:00Z,2\n", "t",
             r"same.csv:3: column 't': the same time as the row before")
    _refused(tmp_path, "back.csv", "t,T1\n2024-03-01T08:00:00Z,1\n2024-03-01T07:00:00Z,2\n", "t",
             r"back.csv:3: .*goes back 3600 s here \(a logger reset or rows out of order\); "
             r"expected times that increase$")
    _refused(tmp_path, "clock.csv", "Uhrzeit;T1\n08:00:00;20,5\n08:00:10;20,6\n", "Uhrzeit",
             r"clock.csv:2: column 'Uhrzeit': '08:00:00' is a clock time without a date; expected a date-time, or "
             r"one date column beside it \(none found\)")
    path = tmp_path / "split.csv"
    path.write_text("Datum;Uhrzeit;T1\n01.03.2024;23:59:50;20,5\n02.03.2024;00:00:10;20,6\n")
    table = read_table(path, "Uhrzeit")
    assert list(table.columns) == ["Uhrzeit", "T1"] and table.columns["Uhrzeit"].tolist() == [0.0, 20.0]
    assert table.read_notes[0] == "Datum + Uhrzeit: date-times read as seconds since 2024-03-01 23:59:50 (the first row)"


def _seconds_file(tmp_path, header, rows):
    (tmp_path / "seconds.csv").write_text("\n".join([",".join(header), *map(",".join, rows)]) + "\n")
    return _fit(tmp_path, "seconds.csv", "seconds.json", time=())[0]


def test_day_first_excel_days_and_a_date_beside_a_clock_fit_to_the_seconds_files_model(tmp_path, fl):
    header, rows = fl
    plain = _seconds_file(tmp_path, header, rows)
    moment = lambda s: START + timedelta(seconds=s)
    slashed = _export(tmp_path / "slashed.csv", header, rows, lambda s: moment(s).strftime("%d/%m/%Y %H:%M:%S"))
    refused = thermoplc("fit", "--data", slashed.name, "--time", "timestamp", "--model", "mlr", "--target", "ch3_um",
                        "--temps", "t5_C,t4_C", "--train-until", 15000, "-o", "x.json", cwd=tmp_path, check=2)
    assert "slashed.csv:2: column 'timestamp': '01/03/2024 08:00:00' reads as day first and as month first" \
        in refused.stderr and "give --time-format day-first" in refused.stderr
    model, _ = _fit(tmp_path, slashed.name, "slashed.json", time=("--time", "timestamp", "--time-format", "day-first"))
    assert _bits(model) == _bits(plain) and model["reading"] == {"time_format": "day-first"}
    day = (START - datetime(1899, 12, 30)).days
    excel = _export(tmp_path / "excel.csv", header, rows, lambda s: f"{day + (8 * 3600 + s) / 86400:.10f}")
    model, result = _fit(tmp_path, excel.name, "excel.json", time=("--time", "timestamp", "--time-format", "excel"))
    assert _bits(model) == _bits(plain)
    assert "timestamp: Excel serial days read as seconds since 2024-03-01 08:00:00 (the first row)" in result.stderr
    thermoplc("generate", "excel.json", "-o", "excel.scl", "--accept-unvalidated", cwd=tmp_path)
    verdict = thermoplc("verify", "excel.scl", "--model", "excel.json", "--data", excel.name, cwd=tmp_path).stdout
    assert verdict.startswith("bit-exact") and "read as the model file records: --time-format excel" in verdict
    split = tmp_path / "split.csv"
    split.write_text("\n".join([";".join(["Datum", "Zeit", *header[1:]]),
                                *(";".join([moment(float(r[0])).strftime("%d.%m.%Y"),
                                            moment(float(r[0])).strftime("%H:%M:%S"),
                                            *(c.replace(".", ",") for c in r[1:])]) for r in rows)]) + "\n")
    model, result = _fit(tmp_path, split.name, "split.json", time=("--time", "Zeit"))
    assert _bits(model) == _bits(plain) and "Datum + Zeit: date-times read as seconds since" in result.stderr


def test_missing_cells_are_held_or_dropped_as_told_counted_and_verify_reads_them_so_again(tmp_path, fl):
    header, rows = fl
    gapped = [list(r) for r in rows]
    for k in (40, 41, 700):  # two cells in a row of t5_C (15 s each) and one in t4_C
        gapped[k][header.index("t5_C" if k < 100 else "t4_C")] = "#N/A"
    (tmp_path / "gaps.csv").write_text("\n".join([",".join(header), *map(",".join, gapped)]) + "\n")
    refused = thermoplc("fit", "--data", "gaps.csv", "--model", "mlr", "--target", "ch3_um", "--temps", "t5_C,t4_C",
                        "--train-until", 15000, "-o", "x.json", cwd=tmp_path, check=2)
    column = header.index("t5_C") + 1
    assert f"gaps.csv:42:{column}: column 't5_C': expected a number, found '#N/A' (a missing value: give --gaps drop" \
        in refused.stderr
    short = thermoplc("fit", "--data", "gaps.csv", "--gaps", "hold:15s", "--model", "mlr", "--target", "ch3_um",
                      "--temps", "t5_C,t4_C", "--train-until", 15000, "-o", "x.json", cwd=tmp_path, check=2)
    assert ("gaps.csv:43: column 't5_C': missing for 30 s since its last value at line 41, longer than --gaps "
            "hold:15s holds (15 s)") in short.stderr
    model, result = _fit(tmp_path, "gaps.csv", "held.json", time=("--gaps", "hold:30s"))
    assert ("--gaps hold:30s: held 3 missing cells in 2 column(s) at their last value, for at most 30 s (the first at "
            "line 42, column 't5_C')") in result.stderr
    assert model["reading"] == {"gaps": "hold:30s"}
    thermoplc("generate", "held.json", "-o", "held.scl", "--accept-unvalidated", cwd=tmp_path)
    verdict = thermoplc("verify", "held.scl", "--model", "held.json", "--data", "gaps.csv", cwd=tmp_path).stdout
    assert verdict.startswith("bit-exact") and "read as the model file records: --gaps hold:30s" in verdict
    assert "--gaps hold:30s: held 3 missing cells" in verdict
    longer = thermoplc("verify", "held.scl", "--model", "held.json", "--data", "gaps.csv", "--gaps", "hold:45s",
                       cwd=tmp_path).stdout
    assert "NOTE: read otherwise than the model's data were: --gaps hold:45s given here, --gaps hold:30s in the model" \
        in longer
    dropped = thermoplc("fit", "--data", "gaps.csv", "--gaps", "drop", "--model", "mlr", "--target", "ch3_um",
                        "--temps", "t5_C,t4_C", "--train-until", 15000, "-o", "x.json", cwd=tmp_path, check=2)
    assert ("gaps.csv:44: column 'time_s': step 45 s (--gaps drop dropped the rows between), expected 15 s ±5%; the "
            "block runs on a fixed cycle: give --resample") in dropped.stderr
    model, result = _fit(tmp_path, "gaps.csv", "dropped.json", time=("--gaps", "drop", "--resample", "15"))
    assert "--gaps drop: dropped 3 of 1,500 rows with a missing cell (the first at line 42, column 't5_C')" \
        in result.stderr
    assert model["reading"] == {"gaps": "drop"} and model["resample"]["period_s"] == 15


def test_a_probed_targets_missing_cell_is_not_measured_there_and_never_held(tmp_path):
    path = tmp_path / "probed.csv"
    path.write_text("time_s,T1,E\n0,1,5\n10,2,#N/A\n20,#N/A,\n30,4,7\n")
    table = read_table(path, sparse=("E",), reading=Reading(gaps="hold", hold_s=10.0))
    assert np.isnan(table.columns["E"][1:3]).all() and table.columns["E"][[0, 3]].tolist() == [5.0, 7.0]
    assert table.columns["T1"].tolist() == [1.0, 2.0, 2.0, 4.0]
    assert "held 1 missing cells in 1 column(s)" in table.read_notes[-1]


def test_npz_excel_days_are_converted_and_text_forms_refused(tmp_path):
    path = tmp_path / "days.npz"
    np.savez(path, t=45352 + (8 * 3600 + np.arange(4) * 15.0) / 86400, T1=np.arange(4.0))
    table = read_table(path, "t", reading=Reading(time_format="excel"))
    assert table.columns["t"].tolist() == [0.0, 15.0, 30.0, 45.0] and table.reading.time_format == "excel"
    with pytest.raises(UserError, match=r"days.npz: --time-format day-first reads date-times written as text"):
        read_table(path, "t", reading=Reading(time_format="day-first"))


def test_reading_options_are_written_exactly_and_hostile_ones_refused(tmp_path):
    for seconds, text in ((1_080_000.0, "hold:1080000s"), (100.00004, "hold:100.00004s"), (0.001, "hold:0.001s")):
        reading = Reading(gaps="hold", hold_s=seconds)
        assert reading.gaps_text == text and Reading.from_doc(reading.to_doc()) == reading
    assert "no strptime pattern" in time_format_problem("%") and time_format_problem("%d/%m/%Y %H:%M") is None
    _refused(tmp_path, "y1.csv", "t,T1\n0001-01-01T00:00:15+01:00,1\n0001-01-01T00:00:30+01:00,2\n", "t",
             r"y1.csv:2: column 't': expected a date-time that exists")
    _refused(tmp_path, "dotted.csv", "t,T1\n01.03.2024 08:00:00,1\n01.03.2024 08:00:15,2\n", "t",
             r"dotted.csv:2: .*dotted dates are written day first", Reading(time_format="month-first"))
    _refused(tmp_path, "numbers.csv", "t,T1\n0,1\n15,2\n", "t",
             r"numbers.csv:2: column 't': --time-format %d.%m.%Y reads date-times written as text",
             Reading(time_format="%d.%m.%Y"))


def test_a_missing_first_time_is_dropped_and_a_hold_as_long_as_the_gap_is_kept(tmp_path):
    path = tmp_path / "first.csv"
    path.write_text("Datum,Zeit,T1\n01.03.2024,#N/A,1\n01.03.2024,23:59:50,2\n02.03.2024,00:00:00,3\n")
    table = read_table(path, "Zeit", reading=Reading(gaps="drop"))
    assert table.columns["Zeit"].tolist() == [0.0, 10.0] and table.lines.tolist() == [3, 4]
    path = tmp_path / "tenths.csv"
    path.write_text("t,x\n0.1,1\n0.2,#N/A\n0.3,#N/A\n0.4,#N/A\n0.5,5\n")
    assert read_table(path, "t", reading=Reading(gaps="hold", hold_s=0.3)).columns["x"].tolist() == [1, 1, 1, 1, 5]
