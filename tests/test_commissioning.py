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
from thermoplc.recordings.table import write_table
from thermoplc.verifier.engines.interpreter import Machine
from thermoplc.verifier.reading.parser import parse_text

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


@pytest.mark.parametrize("engine", ["auto", "interp"])  # the streamed path first, and the whole-recording one
def test_an_enable_column_in_another_case_drives_the_block_on_both_paths(folder, engine):
    """ST names ignore case, so a column `enable` is the block's Enable: a block that ignores it fails
    on the streamed path as on the whole-recording one (both read it); two such columns are refused."""
    thermoplc("generate", GOLDEN / "kalman.json", "-o", "k.scl", "--force", cwd=folder)
    (folder / "k_eno.scl").write_text((folder / "k.scl").read_text().replace("ENO := #Enable;", "ENO := TRUE;"))
    text = (folder / "plc.csv").read_text()
    (folder / "lower.csv").write_text(text.replace("Enable", "enable", 1).replace("Reset", "RESET", 1))
    args = ("--model", GOLDEN / "kalman.json", "--engine", engine)
    good = thermoplc("verify", "k.scl", "--data", "lower.csv", *args, cwd=folder)
    assert good.stdout.startswith("bit-exact") and "enabled on 3958 of 4321 calls, 34 reset" in good.stdout, good.stdout
    bad = thermoplc("verify", "k_eno.scl", "--data", "lower.csv", *args, cwd=folder, check=1)
    assert bad.stdout.startswith("NOT bit-exact") and "output ENO" in bad.stdout
    header, rest = text.split("\n", 1)
    both = "\n".join(f"{line},{line.split(',')[header.split(',').index('Enable')]}" for line in rest.splitlines())
    (folder / "twice.csv").write_text(f"{header.replace('Enable', 'enable')},ENABLE\n{both}\n")
    twice = thermoplc("verify", "k.scl", "--data", "twice.csv", *args, cwd=folder, check=2)
    assert "columns enable, ENABLE could each drive the block input Enable" in twice.stderr


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
def test_header_attributes_fit_step7_and_a_new_block_is_version_0_1(kind):
    for dialect in ("tia", "step7"):
        header = dict(parse_text(golden_block(kind, dialect).read_text()).header)
        title = header["TITLE"].strip("'")
        assert len(title) <= 64 and all(len(header[k]) <= 8 for k in ("AUTHOR", "FAMILY", "NAME"))
        assert header["VERSION"].strip("'") == "0.1"


def _version_line(result) -> str:
    return next(line.strip() for line in result.stdout.splitlines() if line.strip().startswith("VERSION "))


def _changed_model(folder, name: str, beta: float):
    """mlr.json with beta0 moved: another fingerprint, the same kind and evidence."""
    import json
    from thermoplc.base.binary32 import f32_hex
    doc = json.loads((GOLDEN / "mlr.json").read_text())
    doc["coefficients"]["beta0"] = {"f64": beta, "f32": f32_hex(beta)}
    (folder / name).write_text(json.dumps(doc))
    return folder / name


@pytest.mark.parametrize("dialect", ("tia", "step7", "iec"))
def test_the_version_counts_up_when_the_model_changes_and_only_then(folder, dialect):
    (folder / "counted").mkdir(exist_ok=True)
    block = f"counted/v.{dialect}"
    first = thermoplc("generate", GOLDEN / "mlr.json", "--dialect", dialect, "-o", block, cwd=folder)
    assert _version_line(first) == f"VERSION 0.1 (a new block: nothing to replace at {block})"
    text = (folder / block).read_text()
    same = thermoplc("generate", GOLDEN / "mlr.json", "--dialect", dialect, "-o", block, "--force", cwd=folder)
    assert _version_line(same) == "VERSION 0.1 (the block it replaces was 0.1, same model)"
    assert (folder / block).read_text() == text  # same file, same model: the same bytes
    changed = _changed_model(folder, "mlr_changed.json", 0.5)
    up = thermoplc("generate", changed, "--dialect", dialect, "-o", block, "--force", cwd=folder)
    assert _version_line(up) == "VERSION 0.2 (the block it replaces was 0.1, model changed)"
    assert dict(parse_text((folder / block).read_text()).header).get("VERSION", "'0.2'").strip("'") == "0.2"
    back = thermoplc("generate", GOLDEN / "mlr.json", "--dialect", dialect, "-o", block, "--force", cwd=folder)
    assert _version_line(back) == "VERSION 0.3 (the block it replaces was 0.2, model changed)"  # never down
    explicit = thermoplc("generate", GOLDEN / "mlr.json", "--dialect", dialect, "--block-version", "3.4", "-o", block,
                         "--force", cwd=folder)
    assert _version_line(explicit) == "VERSION 3.4 (--block-version)"
    after = thermoplc("generate", changed, "--dialect", dialect, "-o", block, "--force", cwd=folder)
    assert _version_line(after) == "VERSION 3.5 (the block it replaces was 3.4, model changed)"


def test_the_version_carries_at_15_and_stops_at_15_15(folder):
    changed = _changed_model(folder, "mlr_carry.json", 0.25)
    thermoplc("generate", GOLDEN / "mlr.json", "--block-version", "2.15", "-o", "carry.scl", "--force", cwd=folder)
    carried = thermoplc("generate", changed, "-o", "carry.scl", "--force", cwd=folder)
    assert _version_line(carried) == "VERSION 3.0 (the block it replaces was 2.15, model changed)"
    assert "VERSION : 3.0\n" in (folder / "carry.scl").read_text()
    thermoplc("generate", GOLDEN / "mlr.json", "--dialect", "step7", "--block-version", "15.15", "-o", "last.scl",
              "--force", cwd=folder)
    before = (folder / "last.scl").read_text()
    same = thermoplc("generate", GOLDEN / "mlr.json", "--dialect", "step7", "-o", "last.scl", "--force", cwd=folder)
    assert _version_line(same) == "VERSION 15.15 (the block it replaces was 15.15, same model)"
    refused = thermoplc("generate", changed, "--dialect", "step7", "-o", "last.scl", "--force", cwd=folder, check=2)
    assert ("last.scl is VERSION 15.15, the last a block header takes (each part 0 to 15), and the model changed; "
            "give the new block's version with --block-version X.Y; nothing written") in refused.stderr
    assert (folder / "last.scl").read_text() == before
    thermoplc("generate", changed, "--dialect", "step7", "--block-version", "0.1", "-o", "last.scl", "--force",
              cwd=folder)


def test_the_version_of_a_file_thermoplc_did_not_write_or_cannot_count_on(folder):
    (folder / "foreign.scl").write_text('FUNCTION_BLOCK "Mine"\nVERSION : 4.2\nBEGIN\nEND_FUNCTION_BLOCK\n')
    result = thermoplc("generate", GOLDEN / "mlr.json", "-o", "foreign.scl", "--force", cwd=folder)
    assert _version_line(result) == "VERSION 0.1 (foreign.scl, which it replaces, is not a block thermoplc wrote)"
    thermoplc("generate", GOLDEN / "mlr.json", "-o", "edited.scl", "--force", cwd=folder)
    text = (folder / "edited.scl").read_text()
    (folder / "edited.scl").write_text(text.replace("VERSION : 0.1", "VERSION : 16.3"))
    result = thermoplc("generate", GOLDEN / "mlr.json", "-o", "edited.scl", "--force", cwd=folder, check=2)
    assert "edited.scl is a block thermoplc wrote, but its VERSION 16.3 is outside 0.0..15.15" in result.stderr
    result = thermoplc("generate", GOLDEN / "mlr.json", "-o", "-", cwd=folder)
    assert "VERSION 0.1 (written to standard output: no block to replace; --block-version sets it)" in result.stderr


def test_the_header_name_is_stated_when_cut_and_set_with_header_name(folder):
    cut = thermoplc("generate", GOLDEN / "mlr.json", "--dialect", "step7", "-o", "named.scl", "--force", cwd=folder)
    assert ("  NAME ThermalC: the block name cut to the 8 characters STEP 7 allows; --header-name sets it"
            in cut.stdout.splitlines())
    given = thermoplc("generate", GOLDEN / "mlr.json", "--dialect", "step7", "--header-name", "Spindle1",
                      "--instance-db", "ThermalComp_DB", "-o", "named.scl", "--force", cwd=folder)
    assert "  NAME Spindle1: --header-name" in given.stdout.splitlines()
    text = (folder / "named.scl").read_text()
    assert text.count("NAME : Spindle1\n") == 2 and "ThermalC\n" not in text  # the instance DB's too
    short = thermoplc("generate", GOLDEN / "mlr.json", "--name", "Axis_Z", "-o", "short.scl", "--force", cwd=folder)
    assert "  NAME Axis_Z: the block name" in short.stdout.splitlines()
    iec = thermoplc("generate", GOLDEN / "mlr.json", "--dialect", "iec", "-o", "named.st", "--force", cwd=folder)
    assert "NAME" not in iec.stdout  # plain IEC text has no NAME attribute
    refused = thermoplc("generate", GOLDEN / "mlr.json", "--name", "Function_Axis", "--dialect", "step7", "-o",
                        "fn.scl", cwd=folder, check=2)
    assert ("NAME 'Function' (the block name cut to the 8 characters STEP 7 allows): 'Function' is a reserved word"
            in refused.stderr and "set one with --header-name" in refused.stderr)
    assert not (folder / "fn.scl").exists()
    thermoplc("generate", GOLDEN / "mlr.json", "--name", "Function_Axis", "--dialect", "iec", "-o", "fn.st", cwd=folder)


@pytest.mark.parametrize("dialect", ("tia", "step7", "iec"))
def test_names_beyond_the_targets_limits_are_refused_not_cut(folder, dialect):
    long_name = "ThermalCompensation_AxZ1"  # 24 characters: the longest name every dialect keeps
    thermoplc("generate", GOLDEN / "mlr.json", "--dialect", dialect, "--name", long_name, "-o", "long.blk", "--force",
              cwd=folder)
    assert parse_text((folder / "long.blk").read_text()).name == long_name
    result = thermoplc("generate", GOLDEN / "mlr.json", "--dialect", dialect, "--name", long_name + "2", "-o", "x.blk",
                       cwd=folder, check=2)
    assert ("--name 'ThermalCompensation_AxZ12' has 25 characters, at most 24 are allowed (the STEP 7 symbol limit, "
            "kept in every dialect)") in result.stderr and not (folder / "x.blk").exists()
    result = thermoplc("generate", GOLDEN / "mlr.json", "--dialect", dialect, "--instance-db", "Thermal_DB_of_the_axis_Z1",
                       "-o", "x.blk", cwd=folder, check=2)
    assert "argument --instance-db: 'Thermal_DB_of_the_axis_Z1' has 25 characters, at most 24" in result.stderr


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
                          (("--header-name", "ThermalComp"), "argument --header-name: expected a letter"),
                          (("--date", "2026-13-01"), "expected a date YYYY-MM-DD"),
                          (("--instance-db", "DB1"), "argument --instance-db: 'DB1' reads as an absolute address"),
                          (("--instance-db", "ThermDB"), "--instance-db writes a STEP 7 instance DB source")):
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
