"""Issue 63 item 4: messages that lead. A misspelled option names the one meant; a block verified against another
model than it was generated from says so beneath the verdict; a recording given to generate says to fit first;
a missing fl_thermal.csv points at the copy thermoplc ships."""
import pytest

from tests.cli_runner import thermoplc
from tests.golden_models import golden_twin_csv


@pytest.mark.parametrize("argv, said", [
    (("select-sensors", "--data", "t.csv", "--target", "E_z_um", "--temps", "T_motor", "-o", "s.txt"),
     "unrecognized arguments: --temps (--temps: did you mean --candidates?)"),
    (("fit", "--data", "t.csv", "--modle", "mlr", "--target", "E_z_um", "--temps", "T_motor", "-o", "m.json"),
     "unrecognized arguments: --modle (--modle: did you mean --model?)"),
    (("fit", "--data", "t.csv", "--model", "mlr", "--target", "E_z_um", "--temp", "T_motor", "-o", "m.json"),
     "unrecognized arguments: --temp (--temp: did you mean --temps?)"),  # no prefix matching: --temp is no option
])
def test_a_misspelled_option_is_named_with_the_one_meant_before_anything_else(tmp_path, argv, said):
    result = thermoplc(*argv, cwd=tmp_path, check=2)
    assert said in result.stderr and result.stderr.count("\n") == 1


def test_verify_says_beneath_the_verdict_that_the_block_came_from_another_model(tmp_path):
    golden_twin_csv(tmp_path).rename(tmp_path / "t.csv")
    fit = ("fit", "--data", "t.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing")
    thermoplc(*fit, "--train-rows", "600", "-o", "a.json", cwd=tmp_path)
    thermoplc(*fit, "--train-rows", "700", "-o", "b.json", cwd=tmp_path)
    thermoplc("generate", "a.json", "-o", "a.scl", "--accept-unvalidated", cwd=tmp_path)
    lines = thermoplc("verify", "a.scl", "--model", "b.json", "--data", "t.csv", cwd=tmp_path, check=1).stdout.splitlines()
    assert lines[0].startswith("NOT bit-exact")
    assert lines[1].startswith("  NOTE: a.scl was generated from another model (fingerprint ") and "than b.json" in lines[1]
    same = thermoplc("verify", "a.scl", "--model", "a.json", "--data", "t.csv", cwd=tmp_path).stdout
    assert "NOTE" not in same


def test_a_recording_given_to_generate_and_a_missing_bundled_file_say_what_to_do(tmp_path):
    golden_twin_csv(tmp_path).rename(tmp_path / "t.csv")
    said = thermoplc("generate", "t.csv", "-o", "x.scl", cwd=tmp_path, check=2).stderr
    assert "t.csv: a recording (CSV), not a thermoplc model; fit a model on it first" in said
    missing = thermoplc("fit", "--data", "fl_thermal.csv", "--model", "mlr", "--target", "ch3_um", "--temps", "t5_C",
                        "--train-until", "80000", "-o", "m.json", cwd=tmp_path, check=2).stderr
    assert "fl_thermal.csv: cannot read: no such file (thermoplc ships a copy: " in missing


def test_the_other_model_is_named_for_every_dialect_and_verify_takes_the_datas_time_column(tmp_path):
    golden_twin_csv(tmp_path).rename(tmp_path / "t.csv")
    fit = ("fit", "--data", "t.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing")
    thermoplc(*fit, "--train-rows", "600", "-o", "a.json", cwd=tmp_path)
    thermoplc(*fit, "--train-rows", "700", "-o", "b.json", cwd=tmp_path)
    thermoplc("generate", "a.json", "--dialect", "iec", "-o", "a.st", "--accept-unvalidated", cwd=tmp_path)
    thermoplc("generate", "a.json", "--dialect", "iec", "--format", "plcopen", "-o", "a.xml", "--accept-unvalidated",
              cwd=tmp_path)
    for block in ("a.st", "a.xml"):
        lines = thermoplc("verify", block, "--model", "b.json", "--data", "t.csv", cwd=tmp_path, check=1).stdout
        assert lines.splitlines()[1].startswith(f"  NOTE: {block} was generated from another model"), block
    renamed = (tmp_path / "t.csv").read_text().replace("time_s,", "stamp,", 1)
    (tmp_path / "renamed.csv").write_text(renamed)
    said = thermoplc("verify", "a.st", "--model", "a.json", "--data", "renamed.csv", cwd=tmp_path, check=2).stderr
    assert "no time column 'time_s' (set it with --time: --time stamp)" in said
    taken = thermoplc("verify", "a.st", "--model", "a.json", "--data", "renamed.csv", "--time", "stamp", cwd=tmp_path)
    assert taken.stdout.startswith("bit-exact")


def test_words_after_a_double_dash_are_values_and_unicode_digits_are_no_schedule(tmp_path):
    from thermoplc.base.values import every_problem
    assert every_problem("٣")[0] is None and every_problem("3")[0].calls == 3
    said = thermoplc("verify", "--model", "m.json", "--data", "t.csv", "--", "--odd.scl", cwd=tmp_path, check=2).stderr
    assert "unrecognized arguments" not in said and "m.json: cannot read the model" in said
