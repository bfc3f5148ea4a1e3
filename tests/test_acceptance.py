"""The physics gate at generate: a block only for a model with held-out evidence that it compensates."""
import json
from pathlib import Path

import pytest

from tests.cli_runner import thermoplc
from tests.golden_models import GOLDEN
from thermoplc.fitting import acceptance
from thermoplc.models.modelfile import load_model
from thermoplc import api

FL_THERMAL = Path(api.__file__).parent / "data" / "fl_thermal" / "fl_thermal.csv"  # the copy the package ships


def _edited(tmp_path: Path, name: str, **held_out) -> Path:
    """The golden mlr model with its held-out metrics changed (None removes a key)."""
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    for key, value in held_out.items():
        if value is None:
            doc["metrics"]["held_out"].pop(key)
        else:
            doc["metrics"]["held_out"][key] = value
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def test_a_model_clearly_better_than_no_compensation_is_accepted_and_its_header_says_on_what(tmp_path):
    result = thermoplc("generate", GOLDEN / "mlr.json", "-o", "m.scl", cwd=tmp_path)
    assert "accepted on 2160 held-out rows: RMSE 11.37 um, max |error| 21.91 um; no compensation: RMSE 34.44 um" \
        in result.stdout
    text = (tmp_path / "m.scl").read_text()
    assert "// Accepted on 2160 held-out rows: RMSE 11.37 um" in text and "NOT VALIDATED" not in text


@pytest.mark.parametrize("rmse, refused", [(34.0, True), (31.1, True), (30.9, False)])
def test_a_model_not_clearly_better_than_no_compensation_is_refused_with_the_numbers(tmp_path, rmse, refused):
    model = _edited(tmp_path, "m.json", rmse_um=rmse, zero_rmse_um=34.5)  # the bar: 90 % of 34.5 = 31.05
    result = thermoplc("generate", model, "-o", "m.scl", cwd=tmp_path, check=2 if refused else 0)
    assert (tmp_path / "m.scl").exists() is not refused
    if refused:
        assert f"m.json: 2160 held-out rows: RMSE {rmse:g} um" in result.stderr
        assert "no compensation: RMSE 34.5 um" in result.stderr and "not clearly better" in result.stderr
        assert "nothing written" in result.stderr and "Traceback" not in result.stderr


def test_the_flag_writes_a_refused_model_and_the_header_and_output_say_it_is_not_validated(tmp_path):
    model = _edited(tmp_path, "worse.json", rmse_um=40.0, zero_rmse_um=34.5)
    result = thermoplc("generate", model, "-o", "w.scl", "--accept-unvalidated", cwd=tmp_path)
    assert "NOT VALIDATED (--accept-unvalidated): 2160 held-out rows: RMSE 40 um" in result.stdout
    said = acceptance.header_lines(load_model(model))
    assert said[0].startswith("NOT VALIDATED - generated with --accept-unvalidated: 2160 held-out rows")
    assert len(said) > 1 and all(len(line) <= acceptance.HEADER_WIDTH for line in said)
    text = (tmp_path / "w.scl").read_text()
    assert "\n".join(f"// {line}" for line in said) in text


@pytest.mark.parametrize("edit", [{"rows": 0}, {"zero_rmse_um": None}])
def test_a_model_without_held_out_evidence_is_refused_unless_accepted(tmp_path, edit):
    model = _edited(tmp_path, "bare.json", **edit)
    refused = thermoplc("generate", model, "-o", "b.scl", cwd=tmp_path, check=2)
    assert "carries no held-out evidence" in refused.stderr and not (tmp_path / "b.scl").exists()
    thermoplc("generate", model, "-o", "b.scl", "--accept-unvalidated", cwd=tmp_path)
    assert "NOT VALIDATED" in (tmp_path / "b.scl").read_text()


def test_a_training_part_past_the_end_of_the_data_is_refused_naming_where_the_data_end(tmp_path):
    """Issue 52: it used to write a model with nothing held out, which generate then refused."""
    thermoplc("twin", "--hours", 4, "--seed", 2, "-o", "twin.csv", cwd=tmp_path)
    fit = ("fit", "--data", "twin.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
           "-o", "all.json")
    until = thermoplc(*fit, "--train-until", 999999, cwd=tmp_path, check=2)
    assert ("twin.csv: --train-until 999999 leaves no row held out (the data run from 0 s to 14400 s); give a time "
            "before 14400 s, or judge by cross-validation with --folds K") in until.stderr
    rows = thermoplc(*fit, "--train-rows", 1441, cwd=tmp_path, check=2)
    assert "twin.csv: --train-rows 1441 leaves no row held out (the file has 1441 rows)" in rows.stderr
    assert not (tmp_path / "all.json").exists()
    thermoplc(*fit, "--train-rows", 1440, cwd=tmp_path)


def test_a_float32_block_far_from_its_float64_model_is_refused_even_with_the_flag(tmp_path):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["metrics"]["float32_vs_float64_max_um"] = 2.0  # 18 % of the held-out RMSE of 11.37 um
    (tmp_path / "q.json").write_text(json.dumps(doc))
    refused = thermoplc("generate", "q.json", "-o", "q.scl", "--accept-unvalidated", cwd=tmp_path, check=2)
    assert "the float32 block differs from the float64 model by up to 2 um" in refused.stderr
    assert "more than 10% of its held-out RMSE (11.37 um)" in refused.stderr and not (tmp_path / "q.scl").exists()


def test_evidence_reads_the_model_file_and_problem_is_none_only_past_the_bar():
    model = load_model(GOLDEN / "lumped_identified.json")
    found = acceptance.evidence(model)
    assert found.rows == 2160 and found.zero_rmse > found.rmse / acceptance.CLEAR_SHARE
    assert acceptance.problem(model) is None and acceptance.quantisation_problem(model) is None


def test_on_real_data_the_gate_refuses_a_model_barely_better_than_none_and_accepts_dlag(tmp_path):
    """FL_THERMAL ch3, first 24 h: GM(0,N) on t4_C alone predicts the rest at 27.84 um against 30.85 um
    with no compensation (more than 90 % of it); dlag on four sensors at 6.52 um."""
    common = ("--data", FL_THERMAL, "--target", "ch3_um", "--train-until", 86400)
    thermoplc("fit", *common, "--model", "gm0n", "--temps", "t4_C", "-o", "gm0n.json", cwd=tmp_path)
    thermoplc("fit", *common, "--model", "dlag", "--temps", "t8_C,t4_C,t5_C,t11_C", "-o", "dlag.json", cwd=tmp_path)
    refused = thermoplc("generate", "gm0n.json", "-o", "g.scl", cwd=tmp_path, check=2)
    assert "RMSE 27.84 um" in refused.stderr and "no compensation: RMSE 30.85 um" in refused.stderr
    accepted = thermoplc("generate", "dlag.json", "-o", "d.scl", cwd=tmp_path)
    assert "accepted on 5354 held-out rows: RMSE 6.52 um, max |error| 16.11 um" in accepted.stdout


@pytest.mark.parametrize("edit, field", [
    ({"zero_rmse_um": float("inf")}, "held_out.zero_rmse_um"), ({"zero_rmse_um": "1e9"}, "held_out.zero_rmse_um"),
    ({"rows": -1}, "held_out.rows"), ({"rows": 0.5}, "held_out.rows"), ({"rows": True}, "held_out.rows"),
    ({"rmse_um": -5.0}, "held_out.rmse_um"), ({"rmse_um": None}, "held_out.rmse_um"),
    ({"max_abs_um": None}, "held_out.max_abs_um"), ({"zero_max_abs_um": "x"}, "held_out.zero_max_abs_um"),
    ({"protocol": 5}, "held_out.protocol"),
])
def test_malformed_evidence_is_an_error_naming_its_field(tmp_path, edit, field):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["metrics"]["held_out"].update(edit)
    (tmp_path / "m.json").write_text(json.dumps(doc))  # Infinity is what Python writes for inf
    refused = thermoplc("generate", "m.json", "-o", "m.scl", "--accept-unvalidated", cwd=tmp_path, check=2)
    assert f"m.json: field 'metrics.{field}'" in refused.stderr and "Traceback" not in refused.stderr
    assert not (tmp_path / "m.scl").exists()


@pytest.mark.parametrize("value", [None, float("nan"), -1.0, "5"])
def test_a_missing_or_malformed_float32_drift_is_an_error_not_a_pass(tmp_path, value):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["metrics"]["float32_vs_float64_max_um"] = value
    (tmp_path / "m.json").write_text(json.dumps(doc))
    refused = thermoplc("generate", "m.json", "-o", "m.scl", cwd=tmp_path, check=2)
    assert "field 'metrics.float32_vs_float64_max_um'" in refused.stderr


def test_the_float32_drift_is_judged_against_the_training_error_when_nothing_was_held_out(tmp_path):
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["metrics"]["held_out"] = {"rows": 0, "rmse_um": None, "max_abs_um": None}
    doc["metrics"]["float32_vs_float64_max_um"] = 0.5  # 45 % of the training RMSE of 1.1 um
    (tmp_path / "m.json").write_text(json.dumps(doc))
    refused = thermoplc("generate", "m.json", "-o", "m.scl", "--accept-unvalidated", cwd=tmp_path, check=2)
    assert "more than 10% of its training RMSE" in refused.stderr


def test_too_few_held_out_rows_or_a_fold_worse_than_nothing_is_no_acceptance(tmp_path):
    few = _edited(tmp_path, "few.json", rows=99)
    assert "fewer than 100 held-out rows are no evidence" in thermoplc("generate", few, "-o", "f.scl", cwd=tmp_path,
                                                                       check=2).stderr
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["metrics"]["cross_validation"] = [{"label": "rows 2..3", "rmse": 40.0, "zero_rmse": 30.0}]
    (tmp_path / "fold.json").write_text(json.dumps(doc))
    refused = thermoplc("generate", "fold.json", "-o", "g.scl", cwd=tmp_path, check=2)
    assert "but in fold rows 2..3: RMSE 40 against 30 with no compensation" in refused.stderr
