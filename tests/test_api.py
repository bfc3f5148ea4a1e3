"""The public API's example (thermoplc/api.py's docstring) runs as written, on the bundled recording."""
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
