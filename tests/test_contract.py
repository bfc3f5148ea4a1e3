"""The contract the verifier reads constants by (contract/constants.py) says, for every golden model,
exactly what the generator writes: same names, same bits, nothing unknown, nothing missing. The
two are written independently; this is where they must agree."""

import numpy as np
import pytest

from tests.golden_models import GOLDEN
from thermoplc.contract.constants import expected, table_coefficients
from thermoplc.generator.lower import lower
from thermoplc.models.modelfile import load_model
from thermoplc.models.safety import Limits

MODELS = sorted(p.stem for p in GOLDEN.glob("*.json"))


def _bits(values) -> list:
    return [v if isinstance(v, int) else int(np.float32(v).view(np.uint32)) for v in values]


@pytest.mark.parametrize("kind", MODELS)
def test_the_contract_names_every_constant_and_table_the_generator_writes(kind):
    model = load_model(GOLDEN / f"{kind}.json")
    limits = Limits(max_output=250.0, max_step=1.5, temp_max_C=120.0)
    block = lower(model, limits)
    written = {c.name: (c.value,) for c in block.constants}
    written.update({v.name: v.initial for v in block.statics if v.initial is not None})
    wanted, unknown, missing = expected(model, limits, list(written))
    assert unknown == [] and missing == []
    assert {name: _bits(values) for name, values in wanted.items()} == \
           {name: _bits(values) for name, values in written.items()}


def test_a_table_reads_its_coefficients_in_order_from_zero_or_one():
    model = load_model(GOLDEN / "bayes.json")
    edges = table_coefficients(model, "tab_Edge_1")
    assert edges[0] == "edge_1_0" and edges == tuple(f"edge_1_{m}" for m in range(len(edges)))
    assert table_coefficients(model, "tab_Nothing") is None and table_coefficients(model, "c_beta0") is None
    piecewise = load_model(GOLDEN / "piecewise.json")
    assert table_coefficients(piecewise, "tab_Beta_2")[0] == "beta_2_1"


@pytest.mark.parametrize("kind", MODELS)
def test_the_required_constants_are_exactly_the_ones_no_coefficient_gives(kind):
    """What `required` demands is what the generator writes beside the coefficients: a block that
    drops one (a limit written as a literal) is refused, and no block of ours lacks one."""
    from thermoplc.contract.constants import required
    model = load_model(GOLDEN / f"{kind}.json")
    block = lower(model, Limits())
    coefficients = {f"c_{name}" for name in model.coefficients}
    assert {c.name for c in block.constants} - coefficients == required(model)


def _edited(text: str, edit: str) -> str:
    """A hand edit of the golden bayes block that the twin's data never exposes."""
    if edit == "limit written as a literal":
        text = text.replace("    c_TempMax : REAL := 150.0;", "", 1)
        return text.replace("c_TempMax", "200.0")
    if edit == "limit moved to a static":
        text = text.replace("    c_TempMax : REAL := 150.0;", "", 1)
        return text.replace("\nVAR\n", "\nVAR\n    c_TempMax : REAL := 200.0;\n", 1)
    if edit == "reset value moved to a static":
        text = text.replace("    c_Zero : REAL := 0.0;", "", 1)
        return text.replace("\nVAR\n", "\nVAR\n    c_Zero : REAL := 0.5;\n", 1)
    if edit == "settle count written as a literal":
        text = text.replace("    c_OneCall : INT := 1;", "", 1)
        return text.replace("+ c_OneCall", "+ 2")
    if edit == "settle count written as a literal beside its declaration":
        return text.replace("+ c_OneCall", "+ 2")
    if edit == "a shadow table":
        return text.replace("\nVAR\n", "\nVAR\n    tab_Shadow : ARRAY[0..1] OF REAL := [1.0, 2.0];\n", 1)
    raise ValueError(edit)


@pytest.mark.parametrize("edit", ["limit written as a literal", "limit moved to a static",
                                  "reset value moved to a static", "settle count written as a literal",
                                  "settle count written as a literal beside its declaration", "a shadow table"])
def test_verify_refuses_a_block_whose_constants_left_their_place(edit, tmp_path):
    """Found by a hostile review: with only declared constants compared, these passed as bit-exact."""
    from tests.golden_models import golden_twin_csv
    from thermoplc.recordings.table import read_table
    from thermoplc.verifier.replays.replay import verify_against_model
    original = (GOLDEN / "bayes.iec.st").read_text()
    edited = _edited(original, edit)
    assert edited != original
    block = tmp_path / "edited.st"
    block.write_text(edited)
    model = load_model(GOLDEN / "bayes.json")
    table = read_table(golden_twin_csv(tmp_path))
    report = verify_against_model(str(block), model, "bayes.json", table)
    assert not report.ok and report.constant_errors
    assert verify_against_model(str(GOLDEN / "bayes.iec.st"), model, "bayes.json", table).ok


def test_generate_refuses_a_model_file_with_a_coefficient_its_kind_does_not_use(tmp_path):
    """As the user types it: `beta_9` added to an mlr file, or a kalman file relabelled mlr, would give
    a block that verify then rejects; generate refuses the file instead and writes nothing."""
    import json
    from tests.cli_runner import thermoplc
    edited = json.loads((GOLDEN / "mlr.json").read_text())
    edited["coefficients"]["beta_9"] = edited["coefficients"]["beta_1"]
    (tmp_path / "b9.json").write_text(json.dumps(edited))
    relabelled = json.loads((GOLDEN / "kalman.json").read_text())
    relabelled["kind"] = "mlr"
    relabelled["settings"] = {}
    (tmp_path / "k.json").write_text(json.dumps(relabelled))
    result = thermoplc("generate", "b9.json", "-o", "out.scl", cwd=tmp_path, check=2)
    assert "b9.json: field 'coefficients': beta_9 not used by a mlr model" in result.stderr
    # the relabelled file is refused earlier, by its speed input an mlr block has no use for
    result = thermoplc("generate", "k.json", "-o", "out.scl", cwd=tmp_path, check=2)
    assert result.stderr.startswith("thermoplc: error: k.json: ") and "Traceback" not in result.stderr
    assert not (tmp_path / "out.scl").exists()


def test_a_model_file_with_an_input_its_kind_does_not_read_is_refused_by_name(tmp_path):
    """Issue 27 review: a speed input in an mlr file stopped generate with "undeclared 'n_rpm'" and
    verify with a block/model mismatch. An mlr block reads temperatures only, so the input is not
    ignored (the guards would check it): both commands name the file, the field, the input and its role."""
    import json
    from tests.cli_runner import thermoplc
    from tests.golden_models import golden_block, golden_twin_csv
    edited = json.loads((GOLDEN / "mlr.json").read_text())
    edited["inputs"].append({"name": "n_rpm", "column": "n_rpm", "role": "speed", "unit": "rpm"})
    (tmp_path / "speed.json").write_text(json.dumps(edited))
    result = thermoplc("generate", "speed.json", "-o", "out.scl", cwd=tmp_path, check=2)
    assert "speed.json: cannot generate a block: field 'inputs[2]': input 'n_rpm' has role 'speed', which a mlr " \
           "block does not read (it reads T_motor, T_bearing)" in result.stderr
    assert not (tmp_path / "out.scl").exists()
    data = golden_twin_csv(tmp_path)
    for extra in ((), ("--faults",)):
        result = thermoplc("verify", golden_block("mlr", "tia"), "--model", "speed.json", "--data", data, *extra,
                           cwd=tmp_path, check=2)
        assert "speed.json: field 'inputs[2]': input 'n_rpm' (role 'speed') is not an input of " in result.stderr


def test_an_output_limit_moved_out_of_var_constant_is_named(tmp_path):
    """Found by review: with c_OutMax alone in VAR, verify said the block had no safety constants."""
    import re
    from tests.cli_runner import thermoplc
    from tests.golden_models import golden_twin_csv
    text = (GOLDEN / "mlr.tia.scl").read_text()
    line = re.search(r"\n( *c_OutMax : Real := [^\n]*)\n", text).group(1)
    moved = text.replace("\n" + line + "\n", "\n", 1).replace("   VAR \n", "   VAR \n" + line + "\n", 1)
    assert moved.count("c_OutMax : Real") == 1 and moved != text
    (tmp_path / "moved.scl").write_text(moved)
    result = thermoplc("verify", "moved.scl", "--model", GOLDEN / "mlr.json", "--data", golden_twin_csv(tmp_path),
                       cwd=tmp_path, check=2)
    assert "moved.scl: c_OutMax declared outside VAR CONSTANT" in result.stderr


@pytest.mark.parametrize("kind", ["kalman", "lumped"])
def test_a_kind_that_needs_its_ambient_apart_refuses_an_input_that_is_both(kind, tmp_path):
    """Found by review: kalman then said a coefficient was missing, lumped that two names were one."""
    import json
    from thermoplc.base.errors import UserError
    doc = json.loads((GOLDEN / f"{kind}.json").read_text())
    ambient = next(i for i, s in enumerate(doc["inputs"]) if s["role"] == "ambient")
    doc["inputs"][0]["role"] = "temperature,ambient"
    del doc["inputs"][ambient]
    (tmp_path / "both.json").write_text(json.dumps(doc))
    with pytest.raises(UserError, match=rf"both\.json: field 'inputs\[0\]\.role': a {kind} model drives each "
                                        r"temperature by the ambient and needs its ambient sensor apart"):
        load_model(tmp_path / "both.json")


def test_the_models_name_no_constant_of_the_block():
    """The safety logic's values are keyed by what they are (temp_min, out_max); the block's names
    for them (c_TempMin, c_OutMax) are the contract's, read by the generator and the verifier."""
    import re
    from pathlib import Path
    from thermoplc.contract.constants import LIMIT_NAMES, limit_constants
    from thermoplc.models.safety import Limits
    roots = [Path(__file__).resolve().parents[1] / "thermoplc" / folder
             for folder in ("recordings", "physics", "models", "fitting")]
    named = [f"{path.name}:{i}" for root in roots for path in sorted(root.rglob("*.py"))
             for i, line in enumerate(path.read_text("utf-8").splitlines(), 1) if re.search(r"[\"']c_[A-Z]", line)]
    assert named == []
    assert set(LIMIT_NAMES) == set(Limits().values())
    assert limit_constants(Limits())["c_OutMax"] == Limits().values()["out_max"] == 300.0


def test_the_models_name_no_status_output_or_commissioning_input_of_the_block():
    """The reference keys Enable/Reset, ENO, Ready, Limited, Clamped, Invalid and K0 by what they are
    (control:enable, status:ready, k0:1); the block's names are the contract's, and a control keyed
    by a block input's name is refused rather than ignored."""
    import re
    from pathlib import Path
    from thermoplc.contract.outputs import CONTROL_INPUTS, STATUS_OUTPUTS, named
    from thermoplc.models.safety import CONTROL_START, commissioned_predict, k0_key
    roots = [Path(__file__).resolve().parents[1] / "thermoplc" / folder
             for folder in ("recordings", "physics", "models", "fitting")]
    block_names_ = "|".join(["Enable", "Reset", "ENO", "Ready", "Limited", "Clamped", "Invalid", "K0_", "Probe[A-Z]",
                             "SensorsDisagree"])
    named_in_models = [f"{path.name}:{i}" for root in roots for path in sorted(root.rglob("*.py"))
                       for i, line in enumerate(path.read_text("utf-8").splitlines(), 1)
                       if re.search(rf"[\"']({block_names_})", line)]
    assert named_in_models == []
    assert set(CONTROL_INPUTS) == set(CONTROL_START)
    assert set(STATUS_OUTPUTS.values()) == {"ENO", "Ready", "Limited", "Clamped", "Invalid", "ProbeUsed", "ProbeRefused",
                                            "ProbeRefusals", "ProbeSuspect", "SensorsDisagree"}
    from thermoplc.contract.outputs import ENO
    from thermoplc.generator import ir
    assert ir.ENO == ENO
    assert list(named({k0_key(2): 1, "E_z_um": 2, **dict.fromkeys(STATUS_OUTPUTS, 3)}, {})) == \
        ["K0_2", "E_z_um", "Ready", "Limited", "Clamped", "Invalid", "ENO", "ProbeUsed", "ProbeRefused", "ProbeRefusals",
         "ProbeSuspect", "SensorsDisagree"]
    model = load_model(GOLDEN / "mlr.json")
    inputs = {s.name: np.full(4, 20.0, np.float32) for s in model.inputs}
    with pytest.raises(ValueError, match="control keys"):
        commissioned_predict(model, inputs, "f32", Limits(), lambda *a: {}, {"Enable": np.ones(4, bool)})
