"""The commands as a user types them, in a temporary folder."""
import json

import numpy as np
import pytest

from tests.cli_runner import thermoplc
from thermoplc.base.binary32 import f32_bits, f32_from_bits, f32_hex
from thermoplc.generator.lower import lower
from thermoplc.generator.printer import render
from thermoplc.models.kind import fault_key
from thermoplc.models.modelfile import load_model
from thermoplc.models.model import Coefficient, Model
from thermoplc.models.reference import model_inputs, predict
from thermoplc.recordings.table import read_table


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cli")
    thermoplc("twin", "--hours", 10, "--seed", 3, "-o", "twin.csv", cwd=folder)
    return folder


FIT_KALMAN = ("fit", "--data", "twin.csv", "--model", "kalman", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
              "--speed", "n_rpm", "--ambient", "T_env", "--train-until", 18000, "--generations", 5, "--population", 12)


FIT_MLR = ("fit", "--data", "twin.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
           "--train-until", 18000)


def test_twin_is_deterministic(workdir):
    thermoplc("twin", "--hours", 10, "--seed", 3, "-o", "again.csv", cwd=workdir)
    assert (workdir / "again.csv").read_bytes() == (workdir / "twin.csv").read_bytes()
    thermoplc("twin", "--hours", 10, "--seed", 4, "-o", "other.csv", cwd=workdir)
    assert (workdir / "other.csv").read_bytes() != (workdir / "twin.csv").read_bytes()


def test_twin_sensor_faults_follow_paper_000(workdir):
    said = thermoplc("twin", "--hours", 10, "--seed", 3, "--sensor-fault", "offset:T_motor@3600", "-o", "fault.csv",
                     cwd=workdir).stdout
    assert "  sensor fault offset on T_motor from 3600 s: -2 degC (paper 000 eq. 19)\n" in said
    clean, faulty = read_table(workdir / "twin.csv"), read_table(workdir / "fault.csv")
    shift = faulty.columns["T_motor"] - clean.columns["T_motor"]
    t = clean.columns["time_s"]
    assert np.allclose(shift[t < 3600], 0, atol=2e-6) and np.allclose(shift[t >= 3600], -2.0, atol=2e-6)


FIT_BPNN = ("fit", "--data", "twin.csv", "--model", "bpnn", "--target", "E_z_um,yaw_urad,pitch_urad",
            "--temps", "T_motor,T_bearing,T_struct", "--tool-length", "tool_length_mm", "--train-until", 18000,
            "--generations", 6, "--population", 10)


@pytest.mark.parametrize("kind", ["mlr", "kalman", "dlag", "gm0n", "gm1n", "bayes",
                                  pytest.param("bpnn", marks=pytest.mark.slow)])  # the GA-BP fit: 14 s
def test_fit_generate_verify(workdir, kind):
    fit_args = {"kalman": FIT_KALMAN, "bpnn": FIT_BPNN}.get(kind, tuple(kind if a == "mlr" else a for a in FIT_MLR))
    out = thermoplc(*fit_args, "-o", f"{kind}.json", cwd=workdir).stdout
    assert "fit (training)" in out and "prediction (held out)" in out and "RMSE um" in out
    thermoplc("generate", f"{kind}.json", "--dialect", "tia", "-o", f"{kind}.scl", cwd=workdir)
    text = (workdir / f"{kind}.scl").read_text()
    assert text.startswith('FUNCTION_BLOCK "ThermalComp"') and load_model(workdir / f"{kind}.json").fingerprint() in text
    result = thermoplc("verify", f"{kind}.scl", "--model", f"{kind}.json", "--data", "twin.csv", cwd=workdir)
    rows = read_table(workdir / "twin.csv").rows
    assert "bit-exact" in result.stdout and f"{rows} cycles" in result.stdout
    assert "max |float32 - float64|" in result.stdout and "NaN: none" in result.stdout


def test_fit_is_reproducible(workdir):
    thermoplc(*FIT_KALMAN, "-o", "a.json", cwd=workdir)
    thermoplc(*FIT_KALMAN, "-o", "b.json", cwd=workdir)
    assert (workdir / "a.json").read_bytes() == (workdir / "b.json").read_bytes()
    thermoplc("generate", "a.json", "-o", "a.scl", cwd=workdir)
    thermoplc("generate", "a.json", "-o", "b.scl", cwd=workdir)
    assert (workdir / "a.scl").read_bytes() == (workdir / "b.scl").read_bytes()


def test_differential_evolution_optimizer(workdir):
    out = thermoplc(*FIT_KALMAN, "--optimizer", "de", "-o", "de.json", cwd=workdir).stdout
    assert "prediction (held out)" in out
    assert json.loads((workdir / "de.json").read_text())["fit"]["optimizer"] == "de"


def _mutated(model: Model, name: str) -> Model:
    c = model.coefficients[name]
    bumped = f32_from_bits(f32_bits(c.f32) + 1)
    return Model(**{**model.__dict__, "coefficients": {**model.coefficients, name: Coefficient(c.f64, bumped)}})


@pytest.mark.parametrize("constant", ["A_1", "beta_2", "beta0"])
def test_one_ulp_change_of_a_constant_fails_at_the_right_cycle(workdir, constant):
    if not (workdir / "a.json").exists():
        thermoplc(*FIT_KALMAN, "-o", "a.json", cwd=workdir)
    model = load_model(workdir / "a.json")
    mutant = _mutated(model, constant)
    (workdir / "mutant.scl").write_text(render(lower(mutant)))
    table = read_table(workdir / "twin.csv")
    inputs = model_inputs(model, table)
    honest = predict(model, inputs, "f32")["E_z_um"].view(np.uint32)
    changed = predict(mutant, inputs, "f32")["E_z_um"].view(np.uint32)
    cycle = int(np.nonzero(honest != changed)[0][0])
    result = thermoplc("verify", "mutant.scl", "--model", "a.json", "--data", "twin.csv", cwd=workdir, check=1)
    out = result.stdout
    assert "NOT bit-exact" in out
    assert f"first divergent cycle {cycle} " in out
    block_value = predict(mutant, inputs, "f32")["E_z_um"][cycle]
    assert f32_hex(float(block_value)) in out and f32_hex(float(predict(model, inputs, "f32")["E_z_um"][cycle])) in out
    assert "ULP" in out and "block variables at cycle" in out and "TF_1 =" in out


def test_verify_against_a_recorded_trace(workdir):
    if not (workdir / "a.json").exists():
        thermoplc(*FIT_KALMAN, "-o", "a.json", cwd=workdir)
    model = load_model(workdir / "a.json")
    table = read_table(workdir / "twin.csv")
    outputs = predict(model, model_inputs(model, table), "f32")
    lines = ["time_s,Tm,Tb,speed,amb,plc_E,plc_F1,plc_F2"]
    for j in range(table.rows):
        row = [table.columns[c][j] for c in ("time_s", "T_motor", "T_bearing", "n_rpm", "T_env")]
        lines.append(",".join([repr(float(v)) for v in row] + [repr(float(outputs["E_z_um"][j])),
                                                              str(int(outputs[fault_key("T_motor")][j])),
                                                              str(int(outputs[fault_key("T_bearing")][j]))]))
    (workdir / "trace.csv").write_text("\n".join(lines) + "\n")
    thermoplc("generate", "a.json", "-o", "a.scl", "--force", cwd=workdir)
    mapping = "T_motor=Tm,T_bearing=Tb,n_rpm=speed,T_env=amb"
    ok = thermoplc("verify", "a.scl", "--data", "trace.csv", "--expect",
                   "E_z_um=plc_E,Fault_T_motor=plc_F1,Fault_T_bearing=plc_F2", "--inputs", mapping, cwd=workdir)
    assert "bit-exact" in ok.stdout and "recorded outputs (plc_E, plc_F1, plc_F2)" in ok.stdout
    # the mapping of a trace recorded on a block generated before the fault bits had sensor names
    old = thermoplc("verify", "a.scl", "--data", "trace.csv", "--expect", "E_z_um=plc_E,Fault_2=plc_F2",
                    "--inputs", mapping, cwd=workdir, check=2)
    assert ("no output 'Fault_2' to compare with column 'plc_F2'" in old.stderr and "this block names its fault bits "
            "after their sensors; Fault_2 of a block generated before that is Fault_T_bearing here: --expect "
            "Fault_T_bearing=plc_F2" in old.stderr)
    lines[50] = lines[50].rsplit(",", 3)[0] + ",123.5," + ",".join(lines[50].rsplit(",", 2)[1:])
    (workdir / "trace_bad.csv").write_text("\n".join(lines) + "\n")
    bad = thermoplc("verify", "a.scl", "--data", "trace_bad.csv", "--expect", "E_z_um=plc_E",
                    "--inputs", mapping, cwd=workdir, check=1)
    assert "first divergent cycle 49 (line 51" in bad.stdout


def test_a_trace_of_real_bit_patterns_verifies_and_one_bit_off_does_not(workdir):
    """PLC traces export a REAL as its DWORD (16#4120_0000 in TIA, 0x41200000 elsewhere): read as that binary32."""
    if not (workdir / "a.json").exists():
        thermoplc(*FIT_KALMAN, "-o", "a.json", cwd=workdir)
    model = load_model(workdir / "a.json")
    table = read_table(workdir / "twin.csv")
    words = predict(model, model_inputs(model, table), "f32")["E_z_um"].astype(np.float32).view(np.uint32)
    names = ("time_s", "T_motor", "T_bearing", "n_rpm", "T_env")
    lines = [",".join(names) + ",plc_E"]
    for j, word in enumerate(words):
        written = (f"0x{word:08x}", f"16#{word >> 16:04X}_{word & 0xFFFF:04X}", f"DW#16#{word:08X}")[j % 3]
        lines.append(",".join(repr(float(table.columns[c][j])) for c in names) + "," + written)
    (workdir / "hex.csv").write_text("\n".join(lines) + "\n")
    thermoplc("generate", "a.json", "-o", "a.scl", "--force", cwd=workdir)
    assert read_table(workdir / "hex.csv").columns["plc_E"].astype(np.float32).view(np.uint32).tolist() == words.tolist()
    ok = thermoplc("verify", "a.scl", "--data", "hex.csv", "--expect", "E_z_um=plc_E", cwd=workdir)
    assert "bit-exact" in ok.stdout
    lines[31] = lines[31].rsplit(",", 1)[0] + f",0x{words[30] ^ 1:08X}"
    (workdir / "hex_bad.csv").write_text("\n".join(lines) + "\n")
    bad = thermoplc("verify", "a.scl", "--data", "hex_bad.csv", "--expect", "E_z_um=plc_E", cwd=workdir, check=1)
    assert "first divergent cycle 30 (line 32" in bad.stdout
    lines[31] = lines[31].rsplit(",", 1)[0] + ",0x3F80000"
    (workdir / "hex_short.csv").write_text("\n".join(lines) + "\n")
    short = thermoplc("verify", "a.scl", "--data", "hex_short.csv", "--expect", "E_z_um=plc_E", cwd=workdir, check=2)
    assert ("hex_short.csv:32:6: column 'plc_E': expected a number, found '0x3F80000' (a REAL's 32 bits are 8 "
            "hexadecimal digits: 16#3F800000 or 0x3F800000)") in short.stderr


@pytest.mark.parametrize("args, message", [
    (("fit", "--data", "twin.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_nope", "--train-rows", 100,
      "-o", "x.json"), "twin.csv: no column 'T_nope'"),
    (("fit", "--data", "missing.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor", "--train-rows", 100,
      "-o", "x.json"), "missing.csv: cannot read"),
    (("generate", "twin.csv", "-o", "x.scl"), "twin.csv: a recording (CSV), not a thermoplc model; fit a model on it first"),
    (("verify", "twin.csv", "--model", "mlr.json", "--data", "twin.csv"), "twin.csv:1:1: syntax error"),
])
def test_bad_input_is_one_clear_line_and_exit_2(workdir, args, message):
    if not (workdir / "mlr.json").exists():
        thermoplc("fit", "--data", "twin.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
                  "--train-rows", 500, "-o", "mlr.json", cwd=workdir)
    result = thermoplc(*args, cwd=workdir, check=2)
    assert message in result.stderr
    assert "Traceback" not in result.stderr
    assert not (workdir / "x.json").exists() and not (workdir / "x.scl").exists()


def test_demo_runs_on_the_bundled_recording(tmp_path):
    result = thermoplc("demo", "--out", "demo", cwd=tmp_path)
    assert result.stdout.count("bit-exact over 11115 cycles") == 2
    for name in ("mlr.json", "kalman.json", "ThermalCompMlr.scl", "ThermalCompKalman.scl"):
        assert (tmp_path / "demo" / name).exists()
    again = thermoplc("demo", "--out", "demo", cwd=tmp_path, check=2)  # refused before it says anything
    assert again.stdout == "" and "demo/mlr.json: exists" in again.stderr


def test_generate_stats_reports_cost(workdir):
    if not (workdir / "a.json").exists():
        thermoplc(*FIT_KALMAN, "-o", "a.json", cwd=workdir)
    out = thermoplc("generate", "a.json", "-o", "s.scl", "--stats", cwd=workdir).stdout
    assert "cost per call (worst-case path): 89 REAL/INT arithmetic operations (model 44, input guards and output limits 45)" in out
    assert "state: 108 bytes" in out


def test_fit_and_diagnose_write_no_model_file_that_cannot_become_a_block(tmp_path):
    """Both check the model with pipeline.becomes_block before writing: a column or block name that
    is one of the block's own variables is refused there, not only later by generate."""
    thermoplc("twin", "--hours", 6, "--seed", 1, "-o", "twin.csv", cwd=tmp_path)
    text = (tmp_path / "twin.csv").read_text()
    (tmp_path / "ready.csv").write_text(text.replace("T_bearing", "Ready", 1))
    fit = thermoplc("fit", "--data", "ready.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,Ready",
                    "--train-rows", 1000, "-o", "m.json", cwd=tmp_path, check=2)
    diagnose = thermoplc("diagnose", "--data", "twin.csv", "--temps", "T_motor,T_bearing", "--speed", "n_rpm",
                         "--ambient", "T_env", "--target", "E_z_um", "--name", "Ready", "-o", "d.json", cwd=tmp_path,
                         check=2)
    for result, path in ((fit, "m.json"), (diagnose, "d.json")):
        assert f"{path}: not written: the model could not become a block: 'Ready' and 'Ready' are the same " \
               f"identifier" in result.stderr
        assert not (tmp_path / path).exists()


@pytest.mark.parametrize("extra, message", [
    (("--model", "mlr", "--bins", 8), "--bins is read by --model bayes only; --model mlr does not read it, leave it out"),
    (("--model", "dlag", "--seed", 3), "--seed is read by --model kalman or bpnn only; --model dlag does not read it"),
    (("--model", "mlr", "--lag-step", 60), "--lag-step is read by --model dlag only; --model mlr does not read it"),
    (("--model", "gm0n", "--unseen", "nearest"), "--unseen is read by --model bayes only"),
    (("--model", "auto", "--optimizer", "de"), "--optimizer is read by --model kalman only, which --model auto does "
                                               "not try here (kalman needs --speed and --ambient); leave it out"),
])
def test_fit_refuses_an_option_its_kind_does_not_read(workdir, extra, message):
    """Issue 27 review: such an option was silently ignored (exit 0); given explicitly, even at its
    default value, it is refused before any file is read. Issue 60: so are --speed and --ambient columns the kind
    does not read (mlr fitted the same model with them as without), once the data are read."""
    result = thermoplc("fit", "--data", "twin.csv", "--target", "E_z_um", "--temps", "T_motor,T_bearing", *extra,
                       "--train-until", 18000, "-o", "unread.json", cwd=workdir, check=2)
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert not (workdir / "unread.json").exists()
    for role, column in (("--speed", "n_rpm"), ("--ambient", "T_env")):
        roles = thermoplc(*FIT_MLR, role, column, "-o", "roles.json", "--force", cwd=workdir, check=2)
        assert f"thermoplc: error: {role} is read by --model " in roles.stderr and "leave it out" in roles.stderr
    thermoplc(*FIT_MLR[:-2], "--speed", "n_rpm", "--folds", 3, "-o", "roles.json", "--force", cwd=workdir)  # cuts


def test_demo_removes_an_earlier_block_of_a_model_it_now_refuses(tmp_path, monkeypatch, capsys):
    """With --force over an earlier run, a refused model must not leave that run's block beside it."""
    from thermoplc import demo
    out = tmp_path / "demo"
    out.mkdir()
    (out / "ThermalCompMlr.scl").write_text("(* an earlier run's block *)\n")
    (out / "ThermalCompMlr.verify.txt").write_text("bit-exact\n")
    monkeypatch.setattr(demo, "refusal", lambda model: "worse than no compensation" if model.kind == "mlr" else None)
    assert demo.run_demo(out, force=True) == 1
    printed = capsys.readouterr().out
    assert "mlr: no block: worse than no compensation" in printed
    assert f"removed {out / 'ThermalCompMlr.scl'}" in printed
    assert not (out / "ThermalCompMlr.scl").exists() and not (out / "ThermalCompMlr.verify.txt").exists()
    assert (out / "mlr.json").exists() and (out / "ThermalCompKalman.scl").exists()


def test_the_dialect_choices_are_the_printers():
    """`generate --dialect` lists its choices without importing the printer (90 ms on every call):
    a dialect added to the printer must be added there too, and this says so."""
    import argparse
    from thermoplc.commands import generate
    from thermoplc.generator.printer import DIALECTS
    sub = argparse.ArgumentParser().add_subparsers()
    generate.add_parser(sub)
    parser = sub.choices["generate"]
    dialect = next(a for a in parser._actions if a.dest == "dialect")
    assert tuple(dialect.choices) == tuple(DIALECTS)


def test_fit_help_names_every_kind_that_needs_speed_or_ambient():
    """The --speed and --ambient help is written out (the CLI does not import the kinds): it must name
    each kind whose record reads the role."""
    import argparse
    from thermoplc.commands import fit as fit_command
    from thermoplc.models.kinds import registry
    sub = argparse.ArgumentParser().add_subparsers()
    fit_command.add_parser(sub)
    actions = {a.dest: a.help for a in sub.choices["fit"]._actions}
    for role in ("speed", "ambient"):
        needing = [kind.name for kind in registry().values() if role in kind.roles]
        assert needing and all(name in actions[role] for name in needing), (role, needing, actions[role])
