"""Issue 38 item 6: small inputs that one path read and another skipped, each as a user types it."""
import json

from tests.cli_runner import thermoplc
from tests.golden_models import GOLDEN


def test_a_negative_range_follows_its_option_as_help_prints_it(tmp_path):
    default = thermoplc("generate", GOLDEN / "mlr.json", "-o", "-", cwd=tmp_path).stdout
    for argv in (("--temp-range", "-40,150"), ("--temp-range=-40,150",)):
        assert thermoplc("generate", GOLDEN / "mlr.json", *argv, "-o", "-", cwd=tmp_path).stdout == default
    narrowed = thermoplc("generate", GOLDEN / "mlr.json", "--temp-range", "-20.5,80", "-o", "-", cwd=tmp_path).stdout
    assert narrowed != default and "-20.5" in narrowed
    one = thermoplc("generate", GOLDEN / "mlr.json", "--temp-range", "-40", "-o", "x.scl", cwd=tmp_path, check=2)
    assert "expected LOW,HIGH (two numbers), found '-40'" in one.stderr and not (tmp_path / "x.scl").exists()


def test_an_output_ending_in_a_separator_names_a_folder_and_is_refused(tmp_path):
    for argv in (("generate", GOLDEN / "mlr.json", "-o", "new.scl/"),
                 ("twin", "--hours", "1", "-o", "t1/"),
                 ("verify", GOLDEN / "mlr.tia.scl", "--model", GOLDEN / "mlr.json", "--data", "-", "--json", "out/")):
        result = thermoplc(*argv, cwd=tmp_path, check=2)
        assert "ends in a separator, so it names a folder; expected a file name" in result.stderr
        assert list(tmp_path.iterdir()) == []


def test_row_counts_of_a_model_file_are_bounded_by_what_was_recorded(tmp_path):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    recorded = doc["training"]["total_rows"]
    after = recorded - doc["training"]["rows"]
    for field, value, bound in ((("metrics", "held_out", "rows"), 10 ** 12, f"from 0 to {after:,}"),
                                (("metrics", "train", "rows"), recorded + 1, f"from 0 to {recorded:,}"),
                                (("training", "total_rows"), 10 ** 12, "from 0 to 10,000,000,000"),
                                (("metrics", "held_out", "rows"), -1, "a whole number"),
                                (("metrics", "held_out", "rows"), 2.5, "a whole number")):
        edited = json.loads(json.dumps(doc))
        target = edited
        for key in field[:-1]:
            target = target[key]
        target[field[-1]] = value
        (tmp_path / "m.json").write_text(json.dumps(edited))
        result = thermoplc("generate", "m.json", "-o", "b.scl", cwd=tmp_path, check=2)
        assert f"field {'.'.join(field)!r}: {value!r}" in result.stderr and bound in result.stderr, result.stderr
        assert not (tmp_path / "b.scl").exists()


def test_a_control_column_the_block_has_no_input_for_is_named(tmp_path):
    (tmp_path / "twice.st").write_text("FUNCTION_BLOCK Twice\nVAR_INPUT\n    x : REAL;\nEND_VAR\nVAR_OUTPUT\n"
                                       "    y : REAL;\nEND_VAR\n    y := x + x;\nEND_FUNCTION_BLOCK\n")
    rows = ["time_s,x,y_plc,Enable"] + [f"{10 * i},{i}.5,{2 * i + 1},{i % 2}" for i in range(20)]
    (tmp_path / "trace.csv").write_text("\n".join(rows) + "\n")
    result = thermoplc("verify", "twice.st", "--data", "trace.csv", "--expect", "y=y_plc", "--json", "v.json",
                       cwd=tmp_path)
    note = "column 'Enable' of the data not read: the block has no Enable input, so every call ran as written"
    assert note in result.stdout
    assert json.loads((tmp_path / "v.json").read_text())["note"] == note
    rows = ["time_s,x,y_plc"] + [f"{10 * i},{i}.5,{2 * i + 1}" for i in range(20)]
    (tmp_path / "plain.csv").write_text("\n".join(rows) + "\n")
    plain = thermoplc("verify", "twice.st", "--data", "plain.csv", "--expect", "y=y_plc", cwd=tmp_path)
    assert "not read" not in plain.stdout


def test_an_option_of_one_value_given_twice_is_refused_not_the_last_kept(tmp_path):
    """diff, select-sensors and diagnose kept the last --data of two and replayed it without a word."""
    thermoplc("twin", "--hours", "2", "--seed", "3", "-o", "t.csv", cwd=tmp_path)
    block = str(GOLDEN / "mlr.tia.scl")
    for argv, option in ((("diff", block, block, "--data", "t.csv", "--data", "t.csv"), "--data"),
                         (("twin", "--hours", "1", "--seed", "1", "--seed", "2", "-o", "u.csv"), "--seed"),
                         (("generate", GOLDEN / "mlr.json", "-o", "a.scl", "-o", "b.scl"), "-o")):
        result = thermoplc(*argv, cwd=tmp_path, check=2)
        assert f"{option} given twice" in result.stderr and len(result.stderr.splitlines()) == 1, result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.csv"]


def test_two_spellings_of_a_control_input_are_refused_on_every_engine(tmp_path):
    """'Enable' (always 1) beside 'enable' (0 after row 500): the streamed path took 'Enable' silently."""
    thermoplc("twin", "--hours", "2", "--seed", "3", "-o", "t.csv", cwd=tmp_path)
    lines = (tmp_path / "t.csv").read_text().splitlines()
    rows = [lines[0] + ",Enable,enable"] + [f"{row},1,{int(k < 500)}" for k, row in enumerate(lines[1:])]
    (tmp_path / "en.csv").write_text("\n".join(rows) + "\n")
    for engine in ("fast", "interp"):
        result = thermoplc("verify", GOLDEN / "mlr.tia.scl", "--model", GOLDEN / "mlr.json", "--data", "en.csv",
                           "--engine", engine, cwd=tmp_path, check=2)
        assert "columns Enable, enable could each drive the block input Enable" in result.stderr, result.stderr


def test_held_out_rows_of_a_split_fit_add_up_with_the_training_rows(tmp_path):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["training"]["total_rows"] = doc["training"]["rows"] + 10
    (tmp_path / "m.json").write_text(json.dumps(doc))
    result = thermoplc("generate", "m.json", "-o", "b.scl", cwd=tmp_path, check=2)
    assert "field 'metrics.held_out.rows'" in result.stderr and "from 0 to 10 (the rows recorded after" in result.stderr


def test_auto_refuses_a_sensor_that_never_moves_as_mlr_does(tmp_path):
    thermoplc("twin", "--hours", "2", "--seed", "3", "-o", "t.csv", cwd=tmp_path)
    lines = (tmp_path / "t.csv").read_text().splitlines()
    (tmp_path / "x.csv").write_text("\n".join([lines[0] + ",T_const"] + [r + ",20.0" for r in lines[1:]]) + "\n")
    for kind in ("mlr", "auto"):
        result = thermoplc("fit", "--data", "x.csv", "--model", kind, "--target", "E_z_um", "--temps",
                           "T_motor,T_const", "--train-rows", "400", "-o", f"{kind}.json", cwd=tmp_path, check=2)
        assert "x.csv: " in result.stderr and "T_const does not change on the training rows" in result.stderr
    assert thermoplc("generate", GOLDEN / "mlr.json", "-o", "", cwd=tmp_path, check=2).stderr.startswith(
        "thermoplc: error: -o '': an empty name")


def test_a_real_literal_that_rounds_two_ways_and_misplaced_underscores_are_refused(tmp_path):
    """A long decimal rounds to one REAL straight and to another through a double (strtod, then narrowed);
    IEC 61131-3 allows an underscore only between digits."""
    st = (GOLDEN / "mlr.iec.st").read_text()
    (tmp_path / "long.st").write_text(st.replace("c_beta_1 : REAL := 10.538228;",
                                                 "c_beta_1 : REAL := 9.608996868133544921874999999999;", 1))
    (tmp_path / "under.st").write_text(st.replace("c_OutMax : REAL := 78.0;", "c_OutMax : REAL := 78_.0_;", 1))
    (tmp_path / "fine.st").write_text(st.replace("c_OutMax : REAL := 78.0;", "c_OutMax : REAL := 7_8.0;", 1))
    long = thermoplc("diff", GOLDEN / "mlr.iec.st", "long.st", cwd=tmp_path, check=2)
    assert "long.st:67:24: REAL 9.608996868133544921874999999999 rounds to 9.608996391296387 straight to binary32 " \
           "but to 9.608997344970703 through a double" in long.stderr
    assert "under.st:77:26: syntax error" in thermoplc("diff", GOLDEN / "mlr.iec.st", "under.st", cwd=tmp_path,
                                                       check=2).stderr
    thermoplc("diff", GOLDEN / "mlr.iec.st", "fine.st", cwd=tmp_path, check=0)


def test_a_csv_cell_or_header_with_invisible_characters_is_read_the_same_way_by_every_path(tmp_path):
    """A no-break space before a number passed the C parser and failed the careful one, so whether a file
    was read depended on a row far away; 'Reset' with a zero-width space drove nothing, without a word."""
    thermoplc("twin", "--hours", "2", "--seed", "3", "-o", "t.csv", cwd=tmp_path)
    lines = (tmp_path / "t.csv").read_text().splitlines()
    cells = lines[101].split(",")
    cells[4] = "\u00a0" + cells[4]
    (tmp_path / "nb.csv").write_text("\n".join([*lines[:101], ",".join(cells), *lines[102:]]) + "\n")
    (tmp_path / "zw.csv").write_text("\n".join([lines[0] + ",Reset\u200b"] + [r + ",0" for r in lines[1:]]) + "\n")
    for engine in ("fast", "interp"):
        verify = ("verify", GOLDEN / "mlr.tia.scl", "--model", GOLDEN / "mlr.json", "--engine", engine, "--data")
        assert "nb.csv:102:5: column 'T_motor': expected a number, found '\\xa0" in \
            thermoplc(*verify, "nb.csv", cwd=tmp_path, check=2).stderr
        assert "zw.csv:1:14: column name 'Reset\\u200b' holds an invisible character (U+200B)" in \
            thermoplc(*verify, "zw.csv", cwd=tmp_path, check=2).stderr
