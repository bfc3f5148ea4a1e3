"""`--json` of verify, diff and fit as a CI pipeline uses it: documents valid against the schemas
shipped in the package, exact values (bits), the exit status in `ok`/`same`, '-' as one clean
stream, the output rule of every file, and the same bytes for the same inputs."""
from __future__ import annotations

import json
import shutil
from importlib import resources
from pathlib import Path

import jsonschema
import pytest

from tests.cli_runner import thermoplc

GOLDEN = Path(__file__).resolve().parent / "golden"


def schema(name: str) -> dict:
    return json.loads(resources.files("thermoplc").joinpath("schemas", f"{name}_v1.json").read_text("utf-8"))


@pytest.fixture()
def folder(tmp_path, twin_csv):
    shutil.copy(GOLDEN / "mlr.json", tmp_path / "model.json")
    shutil.copy(GOLDEN / "mlr.tia.scl", tmp_path / "block.scl")
    shutil.copy(twin_csv, tmp_path / "data.csv")
    text = (tmp_path / "block.scl").read_text()
    line = next(x for x in text.splitlines() if "c_beta0 : Real :=" in x)
    (tmp_path / "edited.scl").write_text(text.replace(line, line.split(":=")[0] + ":= 1.5;"))
    return tmp_path


def test_verify_json_says_bit_exact_and_is_the_same_bytes_each_run(folder):
    thermoplc("verify", "block.scl", "--model", "model.json", "--data", "data.csv", "--json", "v1.json", cwd=folder)
    thermoplc("verify", "block.scl", "--model", "model.json", "--data", "data.csv", "--json", "v2.json", cwd=folder)
    doc = json.loads((folder / "v1.json").read_text())
    jsonschema.validate(doc, schema("verify"))
    assert doc["ok"] and doc["first_mismatch"] is None and doc["constants"]["differ"] == []
    assert (folder / "v1.json").read_bytes() == (folder / "v2.json").read_bytes()


def test_verify_json_on_standard_output_carries_the_first_mismatch_in_bits(folder):
    result = thermoplc("verify", "edited.scl", "--model", "model.json", "--data", "data.csv", "--json", "-",
                       cwd=folder, check=1)
    doc = json.loads(result.stdout)  # the whole of standard output is the document
    jsonschema.validate(doc, schema("verify"))
    assert not doc["ok"] and "NOT bit-exact" in result.stderr
    mismatch = doc["first_mismatch"]  # the known start cancels beta0 at the first call: a later call differs
    assert mismatch["block"]["type"] == "REAL" and mismatch["block"]["bits"] != mismatch["expected"]["bits"]
    assert doc["constants"]["differ"][0].startswith("c_beta0: block 1.5")


def test_verify_faults_json(folder):
    result = thermoplc("verify", "block.scl", "--model", "model.json", "--data", "data.csv", "--faults", "--json", "-",
                       cwd=folder, check=None)
    doc = json.loads(result.stdout)
    jsonschema.validate(doc, schema("verify_faults"))
    assert doc["cases"] and all(case["bit_exact"] for case in doc["cases"])
    assert doc["ok"] == all(case["safe"] for case in doc["cases"]) and result.returncode == (0 if doc["ok"] else 1)
    commanded = ("reset", "reset-held", "disable", "disable+reset", "reset-after", "reset-far", "reset-stuck", "pause",
                 "pause-flagged", "pause-stuck", "probe-reset", "probe-pause", "late-start")  # Enable/Reset
    assert all((case["error"] is None) == (case["fault"] in commanded) for case in doc["cases"])


def test_diff_json_with_and_without_data(folder):
    same = json.loads(thermoplc("diff", "block.scl", "block.scl", "--json", "-", cwd=folder).stdout)
    jsonschema.validate(same, schema("diff"))
    assert same["same"] and same["behaviour"] is None
    changed = thermoplc("diff", "block.scl", "edited.scl", "--data", "data.csv", "--json", "-", cwd=folder, check=1)
    doc = json.loads(changed.stdout)
    jsonschema.validate(doc, schema("diff"))
    assert not doc["same"] and [c["name"] for c in doc["constants"]] == ["c_beta0"]
    assert doc["constants"][0]["new"]["bits"] == "0x3FC00000" and doc["behaviour"]


def test_fit_json_names_the_model_written(folder):
    thermoplc("fit", "--data", "data.csv", "--model", "mlr", "--temps", "T_motor,T_bearing", "--target", "E_z_um",
              "--train-until", "14400", "-o", "fitted.json", "--json", "fit.json", cwd=folder)
    doc = json.loads((folder / "fit.json").read_text())
    jsonschema.validate(doc, schema("fit"))
    model = json.loads((folder / "fitted.json").read_text())
    assert doc["model_file"] == "fitted.json" and doc["metrics"] == model["metrics"]


@pytest.mark.parametrize("args, message", [
    (("--json", "v.json"), "v.json: exists"),
    (("--json", "data.csv", "--force"), "data.csv: is also an input"),
])
def test_the_json_file_follows_the_output_rule(folder, args, message):
    (folder / "v.json").write_text("mine\n")
    result = thermoplc("verify", "block.scl", "--model", "model.json", "--data", "data.csv", *args, cwd=folder, check=2)
    assert message in result.stderr and (folder / "v.json").read_text() == "mine\n"


def test_an_empty_json_name_is_refused_not_ignored(folder):
    result = thermoplc("verify", "block.scl", "--model", "model.json", "--data", "data.csv", "--json", "", cwd=folder,
                       check=2)
    assert "argument --json: expected a file name or '-', found an empty name" in result.stderr


def test_fit_names_json_onto_its_model_file_as_the_other_output(folder):
    result = thermoplc("fit", "--data", "data.csv", "--model", "mlr", "--temps", "T_motor,T_bearing", "--target",
                       "E_z_um", "--train-until", "14400", "-o", "same.json", "--json", "same.json", cwd=folder, check=2)
    assert "same.json: named for both -o and --json; give each output a file of its own" in result.stderr
    assert not (folder / "same.json").exists()


def test_verify_manifest_json_lists_every_pair_in_manifest_order(folder):
    (folder / "fleet.csv").write_text("block,data,model\nblock.scl,data.csv,model.json\nedited.scl,data.csv,model.json\n"
                                      "block.scl,missing.csv,model.json\n")
    result = thermoplc("verify", "--manifest", "fleet.csv", "--jobs", "2", "--json", "-", cwd=folder, check=2)
    doc = json.loads(result.stdout)
    jsonschema.validate(doc, schema("verify_fleet"))
    assert [p["line"] for p in doc["pairs"]] == [2, 3, 4]
    assert [p["status"] for p in doc["pairs"]] == ["bit-exact", "NOT bit-exact", "error"]
    assert doc["counts"] == {"bit-exact": 1, "NOT bit-exact": 1, "error": 1} and not doc["ok"]
    assert "throughput" in result.stderr  # the table, timings included, on standard error
    again = thermoplc("verify", "--manifest", "fleet.csv", "--json", "-", cwd=folder, check=2)
    assert again.stdout == result.stdout  # one process or two: the same bytes
