"""Enable/ENO, Reset, --retain, the header and the STEP 7 instance DB, end to end as a user types them."""
import re

import numpy as np
import pytest

from tests.golden_models import GOLDEN, golden_block
from tests.cli_runner import thermoplc
from thermoplc.generator.lower import lower
from thermoplc.generator.printer import render
from thermoplc.machines.cascade import simulate
from thermoplc.models.modelfile import load_model
from thermoplc.models.table import write_table
from thermoplc.verifier.interpreter import Machine
from thermoplc.verifier.parser import parse_text

KINDS = ("kalman", "dlag", "bayes", "gm1n", "lumped")  # latches, ring buffers, a clock, a grey state, a simulation


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """12 h of the twin with a PLC program's Enable and Reset: pulses, a held reset, a disabled hour."""
    path = tmp_path_factory.mktemp("commissioning")
    columns = simulate(12, seed=5)
    rows = len(columns["time_s"])
    enable = np.ones(rows)
    enable[1500:1860] = 0
    enable[3000:3003] = 0
    reset = np.zeros(rows)
    reset[[700, 701, 1600, 1860, 2500, 3001]] = 1
    reset[4000:4030] = 1
    (path / "plc.csv").write_text(write_table({**columns, "Enable": enable, "Reset": reset}))
    (path / "mapped.csv").write_text(write_table({**columns, "en_cmd": enable, "rst_cmd": reset}))
    (path / "plain.csv").write_text(write_table(columns))
    return path


QUICK = {("kalman", "tia"), ("dlag", "step7"), ("bayes", "iec"), ("lumped", "iec")}  # every dialect in the quick set


@pytest.mark.parametrize("kind, dialect", [
    pytest.param(kind, dialect, marks=() if (kind, dialect) in QUICK else pytest.mark.slow)
    for kind in KINDS for dialect in ("tia", "step7", "iec")])
def test_reset_and_enable_replay_bit_exact_and_are_exercised(folder, kind, dialect):
    block = f"{kind}.{dialect}.blk"
    thermoplc("generate", GOLDEN / f"{kind}.json", "--dialect", dialect, "--retain", "-o", block, "--force",
              cwd=folder)
    result = thermoplc("verify", block, "--data", "plc.csv", "--model", GOLDEN / f"{kind}.json", cwd=folder)
    assert result.stdout.startswith("bit-exact") and "ENO" in result.stdout
    text = (folder / block).read_text()
    mutant = re.sub(r"(Enable AND #?Reset THEN\n)(\s+#?\w+ := [^\n]*\n)", r"\1", text, count=1)  # one variable not reset
    assert mutant != text
    (folder / f"mutant.{block}").write_text(mutant)
    result = thermoplc("verify", f"mutant.{block}", "--data", "plc.csv", "--model", GOLDEN / f"{kind}.json",
                       cwd=folder, check=1)
    assert result.stdout.startswith("NOT bit-exact")


def test_enable_and_reset_columns_map_with_inputs_and_default_when_absent(folder):
    thermoplc("generate", GOLDEN / "kalman.json", "-o", "k.scl", "--force", cwd=folder)
    mapped = thermoplc("verify", "k.scl", "--data", "mapped.csv", "--model", GOLDEN / "kalman.json", "--inputs",
                       "Enable=en_cmd,Reset=rst_cmd", cwd=folder).stdout
    direct = thermoplc("verify", "k.scl", "--data", "plc.csv", "--model", GOLDEN / "kalman.json", cwd=folder).stdout
    assert mapped.splitlines()[1] == direct.splitlines()[1]
    plain = thermoplc("verify", "k.scl", "--data", "plain.csv", "--model", GOLDEN / "kalman.json", cwd=folder).stdout
    assert plain.startswith("bit-exact")
    bad = folder / "bad.csv"
    bad.write_text((folder / "plc.csv").read_text().replace("\n", "\n", 1))
    lines = (folder / "plc.csv").read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[5].split(",")
    cells[header.index("Reset")] = "2"
    bad.write_text("\n".join([*lines[:5], ",".join(cells), *lines[6:]]) + "\n")
    result = thermoplc("verify", "k.scl", "--data", "bad.csv", "--model", GOLDEN / "kalman.json", cwd=folder, check=2)
    assert "line 6" in result.stderr and "'Reset'" in result.stderr and "0 or 1" in result.stderr


def _state(machine: Machine, skip=("ENO",)) -> dict:
    return {d.name: machine.values[machine.slots[d.name.upper()]] for d in machine.decls
            if d.section in ("static", "output") and d.name not in skip}


@pytest.mark.parametrize("kind", KINDS)
def test_a_disabled_call_changes_nothing_but_eno_and_a_reset_is_a_new_instance(kind):
    model = load_model(GOLDEN / f"{kind}.json")
    program = parse_text(render(lower(model), "iec"))
    columns = simulate(3, seed=2)
    inputs = [{s.name: float(np.float32(columns[s.column][j])) for s in model.inputs} for j in range(400)]
    running = Machine(program)
    for row in inputs[:300]:
        running.call(row)
    before = _state(running)
    running.call({**inputs[300], "Enable": False})
    assert _state(running) == before and running.values[running.slots["ENO"]] is False
    running.call({**inputs[301], "Enable": True, "Reset": True})  # inputs keep their last value, as in a DB
    fresh = Machine(program)
    fresh.call(inputs[301])
    held = {d.name for d in program.decls if d.section == "output" and d.type.base == "REAL"} | {"Limited", "Clamped"}
    assert _state(running, skip=("ENO", *held)) == _state(fresh, skip=("ENO", *held))  # outputs ramp from where they are


def test_retain_in_the_form_each_target_expects():
    model = load_model(GOLDEN / "mlr.json")
    block = lower(model, retain=True)
    tia, iec, step7 = render(block, "tia"), render(block, "iec"), render(block, "step7")
    assert "VAR_OUTPUT RETAIN" in tia and "   VAR RETAIN" in tia and "VAR RETAIN" in iec
    assert "RETAIN" not in re.sub(r"//[^\n]*", "", step7) and "keep the instance DB retentive" in step7
    assert "RETAIN" not in render(lower(model), "tia").split("BEGIN")[0].replace("retentive", "")
    for text in (tia, iec, step7):
        assert parse_text(text).name == "ThermalComp"


@pytest.mark.parametrize("kind", KINDS + ("mlr", "piecewise", "gm0n", "bpnn"))
def test_header_attributes_fit_step7_and_the_version_follows_the_model(kind):
    for dialect in ("tia", "step7"):
        header = dict(parse_text(golden_block(kind, dialect).read_text()).header)
        title = header["TITLE"].strip("'")
        assert len(title) <= 64 and all(len(header[k]) <= 8 for k in ("AUTHOR", "FAMILY", "NAME"))
        fingerprint = load_model(GOLDEN / f"{kind}.json").fingerprint()
        assert header["VERSION"].strip("'") == f"{int(fingerprint[0], 16)}.{int(fingerprint[1], 16)}"


def test_header_options_and_the_instance_db(folder):
    out = thermoplc("generate", GOLDEN / "mlr.json", "--dialect", "step7", "--author", "ACME", "--family", "Spindle",
                    "--block-version", "2.15", "--date", "2026-03-01", "--instance-db", "ThermalComp_DB", "-o",
                    "s7.scl", "--force", cwd=folder)
    text = (folder / "s7.scl").read_text()
    assert "AUTHOR : ACME\nNAME : ThermalC\nFAMILY : Spindle" in text and "VERSION : '2.15'" in text
    assert "// Generated on 2026-03-01." in text
    assert text.rstrip().endswith('DATA_BLOCK "ThermalComp_DB" "ThermalComp"\nTITLE = \'Instance DB of ThermalComp\'\n'
                                  "VERSION : '2.15'\nAUTHOR : ACME\nNAME : ThermalC\nFAMILY : Spindle\n"
                                  '// The memory of "ThermalComp" between calls: enter "ThermalComp_DB" in the symbol '
                                  "table as a DB first.\nBEGIN\nEND_DATA_BLOCK")
    assert "wrote s7.scl" in out.stdout
    assert thermoplc("verify", "s7.scl", "--data", "plc.csv", "--model", GOLDEN / "mlr.json",
                     cwd=folder).stdout.startswith("bit-exact")
    (folder / "other.scl").write_text(text.replace('"ThermalComp_DB" "ThermalComp"', '"ThermalComp_DB" "Other"'))
    result = thermoplc("verify", "other.scl", "--data", "plc.csv", "--model", GOLDEN / "mlr.json", cwd=folder, check=2)
    assert "is an instance of 'Other', not of the block 'ThermalComp'" in result.stderr
    for argv, message in ((("--author", "ACME Corp"), "argument --author: expected a letter"),
                          (("--family", "Thermal_Compensation"), "8 characters at most"),
                          (("--block-version", "16.0"), "each part 0 to 15"),
                          (("--date", "2026-13-01"), "expected a date YYYY-MM-DD"),
                          (("--instance-db", "DB1"), "--instance-db writes a STEP 7 instance DB source")):
        result = thermoplc("generate", GOLDEN / "mlr.json", *argv, "-o", "x.scl", cwd=folder, check=2)
        assert message in result.stderr and not (folder / "x.scl").exists()


def test_the_default_date_follows_source_date_epoch(folder, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")  # 2026-01-01T00:00:00Z
    thermoplc("generate", GOLDEN / "mlr.json", "-o", "dated.scl", "--force", cwd=folder)
    assert "// Generated on 2026-01-01." in (folder / "dated.scl").read_text()


@pytest.mark.parametrize("dialect, assignment, edit, exact", [
    ("tia", "ENO := #Enable;", "IF #Enable THEN ENO := TRUE; END_IF;", False),  # ENO stays TRUE when disabled
    ("step7", "OK := Enable;", "IF Enable THEN OK := TRUE; END_IF;", False),
    ("tia", "ENO := #Enable;", "IF NOT #Enable THEN ENO := FALSE; END_IF;", True),  # ENO starts TRUE at each call
    ("step7", "OK := Enable;", "IF NOT Enable THEN OK := FALSE; END_IF;", True),
    ("tia", "ENO := #Enable;", "", False),  # no ENO written: a TIA block's ENO is TRUE on every call
    ("iec", "ENO := Enable;", "IF NOT Enable THEN ENO := FALSE; END_IF;", False),  # a declared ENO keeps its value
])
def test_the_scl_enable_flag_starts_each_call_true(folder, dialect, assignment, edit, exact):
    source = render(lower(load_model(GOLDEN / "mlr.json")), dialect)
    assert assignment in source
    (folder / f"eno.{dialect}.blk").write_text(source.replace(assignment, edit, 1))
    result = thermoplc("verify", f"eno.{dialect}.blk", "--data", "plc.csv", "--model", GOLDEN / "mlr.json",
                       cwd=folder, check=0 if exact else 1)
    assert result.stdout.startswith("bit-exact" if exact else "NOT bit-exact")


def test_diff_sees_retain_and_the_instance_db(folder):
    for name, extra in (("plain", ()), ("kept", ("--retain",)), ("db", ("--instance-db", "ThermDB"))):
        thermoplc("generate", GOLDEN / "mlr.json", "--dialect", "step7" if name == "db" else "tia", *extra,
                  "-o", f"{name}.scl", "--force", cwd=folder)
    result = thermoplc("diff", "plain.scl", "kept.scl", cwd=folder, check=1)
    assert "~ RETAIN: (none) -> 'output, static'" in result.stdout
    thermoplc("generate", GOLDEN / "mlr.json", "--dialect", "step7", "-o", "nodb.scl", "--force", cwd=folder)
    result = thermoplc("diff", "nodb.scl", "db.scl", cwd=folder, check=1)
    assert "~ INSTANCE DB: (none) -> 'ThermDB'" in result.stdout
