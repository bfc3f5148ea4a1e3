"""The public API's example (thermoplc/api.py's docstring) runs as written, on the bundled recording."""
import re
from dataclasses import replace
from pathlib import Path

import pytest

from thermoplc import api
from thermoplc.base.errors import UserError

DATA = Path(api.__file__).parent / "data" / "fl_thermal" / "fl_thermal.csv"


@pytest.fixture(scope="module")
def fitted():
    table = api.read_table(DATA)
    return table, api.fit([table], api.FitRequest("mlr", target="ch3_um", temps=("t1_C", "t5_C"), train_until=86400.0))


def test_fit_generate_verify_diff_through_the_api(fitted, tmp_path):
    table, model = fitted
    block = api.generate(model, "model.json")
    path = tmp_path / "ThermalComp.scl"
    path.write_text(block.text)
    report = api.verify(path, model, table)
    assert report.ok and report.cycles == table.rows and report.constants_checked > 0
    assert api.diff(path, path).structurally_equal
    changed = tmp_path / "changed.scl"
    changed.write_text(block.text.replace("c_beta_1 : Real := -", "c_beta_1 : Real := ", 1))
    assert not api.diff(path, changed).structurally_equal
    assert not api.verify(changed, model, table).ok


def test_generate_refuses_what_the_cli_refuses_and_names_the_file(fitted):
    _, model = fitted
    with pytest.raises(UserError, match="model.json: .*nothing written"):
        api.generate(replace(model, metrics={}), "model.json")
    with pytest.raises(UserError, match="plcopen wraps the iec dialect"):
        api.generate(model, "model.json", plcopen=True)


@pytest.mark.parametrize("fields, message", [
    ({"temps": "t1_C"}, "--temps: expected a tuple of column names, found the string 't1_C' (give ('t1_C',))"),
    ({"choose_sensors": -1}, "--choose-sensors: expected a sensor count from 0 to 64, found -1"),
    ({"choose_sensors": 1.5}, "--choose-sensors: expected an integer, found 1.5"),
    ({"train_until": float("nan")}, "--train-until: expected seconds from -1e+12 to 1e+12, found nan"),
    ({"train_until": None, "train_rows": True}, "--train-rows: expected an integer, found True"),
    ({"kind": "mlp"}, "--model: expected one of mlr, kalman"),
    ({"target": None}, "--target: expected a column name, found None"),
    ({"speed": 3}, "--speed: expected a column name, found 3"),
    ({"settings": 5}, "settings: expected a mapping of option to value, found 5"),
])
def test_a_request_the_command_line_would_refuse_is_one_line(fields, message):
    """Issue 60: the API's request took NaN (nothing held out), 1.5 sensors, a string for a tuple ("column 'o' is
    given twice"), and raised StopIteration or TypeError; now the command line's words."""
    request = {"kind": "mlr", "target": "ch3_um", "temps": ("t1_C", "t5_C"), "train_until": 86400.0, **fields}
    with pytest.raises(UserError) as refused:
        api.FitRequest(**request)
    assert message in str(refused.value) and "\n" not in str(refused.value)


def test_the_api_refuses_what_the_kind_does_not_read_and_wrong_types(fitted):
    table, model = fitted
    base = {"kind": "mlr", "target": "ch3_um", "temps": ("t1_C", "t5_C"), "train_until": 86400.0}
    cases = [((table, api.FitRequest(**base)), "tables: expected a list of tables, one per run, found one Table"),
             (([table], api.FitRequest(**base, settings={"bins": 4})),
              "--bins is read by --model bayes only; --model mlr does not read it, leave it out"),
             (([table], api.FitRequest(**base, ambient="t6_C")), "--ambient is read by --model kalman, piecewise or "
                                                                  "lumped only; --model mlr does not read it"),
             (([table], "mlr"), "request: expected a FitRequest, found str 'mlr'"),
             (([], api.FitRequest(**base)), "tables: an empty list")]
    for args, message in cases:
        with pytest.raises(UserError, match=re.escape(message)):
            api.fit(*args)
    assert api.FitRequest(**{**base, "temps": ["t1_C", "t5_C"]}) == api.FitRequest(**base)  # a list is the tuple
    with pytest.raises(UserError, match="model: expected a Model"):
        api.verify("block.scl", "model.json", table)
    with pytest.raises(UserError, match="table: expected a Table"):
        api.verify("block.scl", model, "fl.csv")
    with pytest.raises(UserError, match="model: expected a Model"):
        api.generate("model.json")
    with pytest.raises(UserError, match="no column 'nope'"):
        api.fit([table], api.FitRequest(**base), time_column="nope")
    with pytest.raises(UserError, match=re.escape("overrides['t1_C']: expected a column name, found int 5")):
        api.verify("block.scl", model, table, overrides={"t1_C": 5})
    with pytest.raises(UserError, match="identity: expected a thermoplc.generator.ir.Identity"):
        api.generate(model, "model.json", identity="x")
    request = dict(data=(str(DATA),), temps=("t5_C",), speed="spindle_rpm", ambient="t6_C", target="ch3_um")
    assert api.DiagnoseRequest(**{**request, "data": (DATA,)}).data == (str(DATA),)  # a Path is its path
    for fields, message in (({"resample_s": float("nan")}, "--resample: expected the block's cycle in seconds"),
                            ({"resample_s": -40.0}, "--resample: expected the block's cycle in seconds"),
                            ({"data": str(DATA)}, "--data: expected a tuple of recordings or folders"),
                            ({"data": ()}, "--data: an empty tuple"),
                            ({"reading": "x"}, "reading: expected a thermoplc.recordings.reading.Reading"),
                            ({"block_name": "1x"}, "--name: block name '1x' must start with a letter"),
                            ({"structure_lag": "no"}, "structure_lag: expected True or False, found 'no'")):
        with pytest.raises(UserError, match=re.escape(message)):
            api.DiagnoseRequest(**{**request, **fields})
