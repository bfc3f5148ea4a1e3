"""Fault bits named after their sensor (issue 28 item 10): Fault_T_motor where the name fits every
dialect's limits and is unique, Fault_<i> otherwise; the verifier reads them back by the same rule
(contract/outputs.py) and still proves a block generated with the numbered bits."""
import json
import re

import pytest

from tests.cli_runner import thermoplc
from tests.golden_models import DIALECTS, GOLDEN, KINDS, golden_block, golden_twin_csv
from thermoplc.contract.outputs import block_names, fault_outputs, numbered_fault_outputs
from thermoplc.generator.lower import lower
from thermoplc.models.kind import fault_key
from thermoplc.models.modelfile import load_model
from thermoplc.verifier.reading.block_file import parse_file


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    path = tmp_path_factory.mktemp("fault_names")
    golden_twin_csv(path)
    return path


def _outputs(path) -> list:
    return [d for d in parse_file(path).decls if d.section == "output"]


@pytest.mark.parametrize("kind", KINDS)
def test_each_fault_bit_is_named_after_its_sensor_in_every_dialect(kind):
    model = load_model(GOLDEN / f"{kind}.json")
    wanted = [f"Fault_{s.name}" for s in model.inputs]
    assert list(fault_outputs(model).values()) == wanted  # every golden input name fits
    assert [v.name for v in lower(model).outputs if v.name.startswith("Fault_")] == wanted
    for dialect in DIALECTS:
        declared = [d for d in _outputs(golden_block(kind, dialect)) if d.name.startswith("Fault_")]
        assert [d.name for d in declared] == wanted
    text = golden_block(kind, "tia").read_text()
    for s in model.inputs:  # the comment keeps naming the sensor
        assert re.search(rf"Fault_{s.name} : Bool;   // {s.name} faulty: ", text)


def _renamed(folder, name: str, names: dict) -> str:
    """mlr.json with its inputs renamed in the block (their columns stay): another model file."""
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    for item in doc["inputs"]:
        item["name"] = names.get(item["name"], item["name"])
    for relation in doc["plausibility"]:
        relation["sensor"] = names.get(relation["sensor"], relation["sensor"])
        relation["slopes"] = {names.get(k, k): v for k, v in relation["slopes"].items()}
    (folder / name).write_text(json.dumps(doc))
    return name


def test_a_name_too_long_or_taken_keeps_the_numbered_bit_and_verifies(folder):
    long_name = "T_spindle_motor_front"  # Fault_T_spindle_motor_front: 27 characters, over the 24 of STEP 7
    model_path = _renamed(folder, "long.json", {"T_motor": long_name})
    assert fault_outputs(load_model(folder / model_path)) == {long_name: "Fault_1", "T_bearing": "Fault_T_bearing"}
    for dialect in DIALECTS:
        block = f"long.{dialect}.blk"
        thermoplc("generate", model_path, "--dialect", dialect, "-o", block, cwd=folder)
        declared = _outputs(folder / block)
        assert [d.name for d in declared if d.name.startswith("Fault_")] == ["Fault_1", "Fault_T_bearing"]
        result = thermoplc("verify", block, "--model", model_path, "--data", "golden_twin.csv", cwd=folder)
        assert result.stdout.startswith("bit-exact") and "Fault_1, Fault_T_bearing" in result.stdout
    faults = thermoplc("verify", "long.tia.blk", "--model", model_path, "--data", "golden_twin.csv", "--faults",
                       cwd=folder)
    assert f"\n{long_name:<16}" in faults.stdout and "NOT" not in faults.stdout
    # an input named like another input's fault bit: that input keeps the numbered one
    taken = _renamed(folder, "taken.json", {"T_bearing": "Fault_T_motor"})
    assert fault_outputs(load_model(folder / taken)) == {"T_motor": "Fault_1", "Fault_T_motor": "Fault_Fault_T_motor"}
    thermoplc("generate", taken, "-o", "taken.scl", cwd=folder)
    result = thermoplc("verify", "taken.scl", "--model", taken, "--data", "golden_twin.csv", cwd=folder)
    assert result.stdout.startswith("bit-exact") and "Fault_1, Fault_Fault_T_motor" in result.stdout


def _numbered(text: str, model) -> str:
    """The block text as thermoplc wrote it before the fault bits had sensor names."""
    for name, output in fault_outputs(model).items():
        text = re.sub(rf"\b{output}\b", numbered_fault_outputs(model)[name], text)
    return text


def test_verify_still_proves_a_block_with_the_numbered_fault_bits(folder):
    model = load_model(GOLDEN / "kalman.json")
    (folder / "old.scl").write_text(_numbered(golden_block("kalman", "tia").read_text(), model))
    assert block_names(model, ["E_z_um", "Fault_1", "Fault_2", "Fault_3", "Fault_4"])[fault_key("n_rpm")] == "Fault_3"
    for engine in ("interp", "auto"):
        result = thermoplc("verify", "old.scl", "--model", GOLDEN / "kalman.json", "--data", "golden_twin.csv",
                           "--engine", engine, cwd=folder)
        assert result.stdout.startswith("bit-exact") and "Fault_1, Fault_2, Fault_3, Fault_4" in result.stdout
    faults = thermoplc("verify", "old.scl", "--model", GOLDEN / "kalman.json", "--data", "golden_twin.csv",
                       "--faults", cwd=folder, check=None)
    assert "NOT" not in faults.stdout and faults.returncode in (0, 1)
    failed = [line.split(": ", 1)[1] for line in faults.stdout.splitlines() if "case(s) FAILED" in line]
    assert not failed or all(case.endswith("/sine") for case in failed[0].split(", "))  # issue 61 item 4
    # half renamed is neither block's naming: refused, naming the outputs the model's block has
    mixed = golden_block("kalman", "tia").read_text().replace("Fault_T_motor", "Fault_1")
    (folder / "mixed.scl").write_text(mixed)
    result = thermoplc("verify", "mixed.scl", "--model", GOLDEN / "kalman.json", "--data", "golden_twin.csv",
                       cwd=folder, check=2)
    assert "do not match the outputs of kalman.json: E_z_um, K0_1, Fault_T_motor, Fault_T_bearing" in result.stderr


def test_diff_shows_the_renamed_fault_bits(folder):
    model = load_model(GOLDEN / "mlr.json")
    (folder / "new.scl").write_text(golden_block("mlr", "tia").read_text())
    (folder / "old_mlr.scl").write_text(_numbered(golden_block("mlr", "tia").read_text(), model))
    for extra in ((), ("--data", "golden_twin.csv")):
        result = thermoplc("diff", "old_mlr.scl", "new.scl", *extra, cwd=folder, check=1)
        lines = result.stdout.splitlines()
        for line in ("  - output Fault_1 : BOOL", "  - output Fault_2 : BOOL", "  + output Fault_T_motor : BOOL",
                     "  + output Fault_T_bearing : BOOL"):
            assert line in lines
    assert "  Fault_T_motor: in one block only, or declared with another type: not comparable" in lines
    assert "  E_z_um: identical" in lines
