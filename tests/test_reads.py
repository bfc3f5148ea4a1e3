"""Every input stays an input (issue 60): each option of every command that reads a file is declared so
(thermoplc/commands/reads.py), and no output of the command — -o, --json, --outputs — may replace any file it read,
not even with --force: the recording, a folder's runs table, a run the table names, an @FILE list, a model,
a block, a manifest and the files of its pairs."""
from __future__ import annotations

import argparse
import shutil

import numpy as np
import pytest

from thermoplc.cli import build_parser, main
from thermoplc.commands.reads import Reads, Writes
from thermoplc.recordings.table import write_table
from thermoplc.machines.cascade import simulate

# options whose value is text but no file: column names, block names, schedules of effects and faults
VALUES = {("twin", "sensor_fault"), ("twin", "effect"), ("fit", "speed"), ("fit", "ambient"), ("fit", "time"),
          ("fit", "group_by"), ("fit", "tool_length"), ("fit", "name"), ("select-sensors", "target"),
          ("select-sensors", "time"), ("diagnose", "speed"), ("diagnose", "ambient"), ("diagnose", "target"),
          ("diagnose", "feed"), ("diagnose", "time"), ("diagnose", "name"), ("generate", "name"),
          ("diff", "probe_target"), ("diff", "time"), ("verify", "time")}


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


def _free_text(action: argparse.Action) -> bool:
    """An option that takes any text (no choices, no number or format of its own): it could name a file."""
    kind = action.type
    return action.nargs != 0 and action.choices is None and (
        kind is None or getattr(kind, "__qualname__", "").startswith("named."))


def _reading_options() -> set[tuple[str, str]]:
    return {(name, a.dest) for name, p in _commands().items() for a in p._actions if isinstance(a.type, Reads)}


def test_every_option_that_could_name_a_file_is_declared_read_written_or_a_value():
    undeclared = {(name, a.dest) for name, p in _commands().items() for a in p._actions
                  if _free_text(a) and not isinstance(a.type, (Reads, Writes)) and a.dest != "help"}
    assert undeclared - VALUES == set(), "declare these options Reads/Writes (thermoplc/commands/reads.py) or a value"
    writes = {(name, a.dest) for name, p in _commands().items() for a in p._actions if isinstance(a.type, Writes)}
    assert {("fit", "output"), ("fit", "json"), ("fit", "report"), ("diagnose", "json"), ("verify", "outputs"),
            ("generate", "output"), ("demo", "out")} <= writes


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A recording, a campaign folder with its runs.csv, @FILE lists, a model, its block and a manifest."""
    where = tmp_path_factory.mktemp("reads")
    (where / "run.csv").write_text(write_table(simulate(4, seed=3)))
    (where / "camp").mkdir()
    shutil.copy(where / "run.csv", where / "camp" / "a.csv")
    (where / "camp" / "runs.csv").write_text("file\na.csv\n")
    (where / "temps.txt").write_text("T_motor,T_bearing\n")
    (where / "target.txt").write_text("E_z_um\n")
    (where / "expect.csv").write_text("E_z_um\n")
    fit = ["fit", "--data", str(where / "run.csv"), "--model", "mlr", "--target", "E_z_um", "--temps",
           "T_motor,T_bearing", "--train-until", "7200", "-o", str(where / "m.json")]
    assert main(fit) == 0
    assert main(["generate", str(where / "m.json"), "-o", str(where / "b.scl"), "--accept-unvalidated"]) == 0
    (where / "manifest.csv").write_text("block,data,model\nb.scl,run.csv,m.json\n")
    for sub, source in (("", "b.scl"), ("tm", "m.json"), ("td", "run.csv")):  # each named as the bench it reads
        (where / sub).mkdir(exist_ok=True)
        shutil.copy(where / source, where / sub / "ThermalComp_TB.scl")
    return where


FIT = ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "--train-until", "7200")
DIAGNOSE = ("diagnose", "--temps", "T_motor", "--speed", "n_rpm", "--ambient", "T_env", "--target", "E_z_um")
VERIFY = ("verify", "b.scl", "--model", "m.json")
# (command, option read): command lines whose output is a file that option made the command read
CASES = {
    ("fit", "data"): [(*FIT, "--data", "run.csv", "-o", "run.csv", "--force"),
                      (*FIT, "--data", "camp", "-o", "camp/runs.csv", "--force"),
                      (*FIT, "--data", "camp", "-o", "x.json", "--json", "camp/a.csv", "--force")],
    ("fit", "runs"): [(*FIT, "--runs", "camp/runs.csv", "-o", "camp/runs.csv", "--force")],
    ("fit", "target"): [("fit", "--data", "run.csv", "--model", "mlr", "--target", "@target.txt", "--temps", "T_motor",
                         "--train-until", "7200", "-o", "target.txt", "--force")],
    ("fit", "temps"): [("fit", "--data", "run.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "@temps.txt",
                        "--train-until", "7200", "-o", "x.json", "--json", "temps.txt", "--force")],
    ("select-sensors", "data"): [("select-sensors", "--data", "run.csv", "--target", "E_z_um", "-o", "run.csv",
                                  "--force")],
    ("select-sensors", "candidates"): [("select-sensors", "--data", "run.csv", "--target", "E_z_um", "--candidates",
                                        "@temps.txt", "-o", "temps.txt", "--force")],
    ("diagnose", "data"): [(*DIAGNOSE, "--data", "camp", "-o", "camp/runs.csv", "--force")],
    ("diagnose", "runs"): [(*DIAGNOSE, "--runs", "camp/runs.csv", "--json", "camp/a.csv", "--force")],
    ("diagnose", "temps"): [("diagnose", "--data", "run.csv", "--temps", "@temps.txt", "--speed", "n_rpm", "--ambient",
                             "T_env", "--target", "E_z_um", "-o", "temps.txt")],
    ("diagnose", "baseline"): [(*DIAGNOSE, "--data", "run.csv", "--baseline", "m.json", "--json", "m.json",
                                "--force")],
    ("generate", "model"): [("generate", "m.json", "-o", "m.json", "--force")],
    ("diff", "old"): [("diff", "b.scl", "m.json", "--json", "b.scl", "--force")],
    ("diff", "new"): [("diff", "m.json", "b.scl", "--json", "b.scl", "--force")],
    ("diff", "data"): [("diff", "b.scl", "b.scl", "--data", "run.csv", "--json", "run.csv", "--force")],
    ("verify", "block"): [(*VERIFY, "--data", "run.csv", "--json", "b.scl", "--force")],
    ("verify", "data"): [(*VERIFY, "--data", "camp", "--outputs", "camp/runs.csv", "--force"),
                         (*VERIFY, "--data", "camp", "--json", "camp/runs.csv", "--force")],
    ("verify", "runs"): [(*VERIFY, "--runs", "camp/runs.csv", "--json", "camp/a.csv", "--force")],  # no output at all
    ("verify", "model"): [(*VERIFY, "--data", "run.csv", "--json", "m.json", "--force")],
    ("testbench", "block"): [("testbench", "ThermalComp_TB.scl", "--model", "m.json", "--data", "run.csv", "-o", ".",
                              "--force")],
    ("testbench", "model"): [("testbench", "b.scl", "--model", "tm/ThermalComp_TB.scl", "--data", "run.csv", "-o",
                              "tm", "--force")],
    ("testbench", "data"): [("testbench", "b.scl", "--model", "m.json", "--data", "td/ThermalComp_TB.scl", "-o",
                             "td", "--force")],
    ("verify", "expect"): [("verify", "b.scl", "--data", "run.csv", "--expect", "@expect.csv", "--outputs",
                            "expect.csv", "--force")],
    ("verify", "manifest"): [("verify", "--manifest", "manifest.csv", "--json", "manifest.csv", "--force"),
                             ("verify", "--manifest", "manifest.csv", "--json", "m.json", "--force")],
}


def test_every_reading_option_of_every_command_has_a_case():
    assert set(CASES) == _reading_options()


@pytest.mark.parametrize("key", sorted(CASES), ids=lambda key: "-".join(key))
def test_no_output_replaces_a_file_the_command_read(key, folder, monkeypatch, capsys):
    monkeypatch.chdir(folder)
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    for argv in CASES[key]:
        assert main(list(argv)) == 2, argv
        said = capsys.readouterr().err
        why = "take one recording" if key == ("verify", "runs") else "is also an input of this command"
        assert said.count("\n") == 1 and why in said, (argv, said)
        assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()} == before, argv


def test_the_api_refuses_to_write_onto_what_it_reads(folder, monkeypatch):
    from thermoplc.api import DiagnoseRequest, diagnose
    from thermoplc.base.errors import UserError
    monkeypatch.chdir(folder)
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    request = DiagnoseRequest(("camp",), ("T_motor",), "n_rpm", "T_env", "E_z_um", baseline="m.json")
    for model_path, json_path in (("camp/a.csv", None), ("out.json", "camp/runs.csv"), ("m.json", None)):
        with pytest.raises(UserError, match="is also an input of this command"):
            diagnose(request, model_path, json_path)
    assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()} == before


def test_diagnose_baseline_refuses_a_fused_model_and_takes_a_period_rounded_by_large_time_stamps(tmp_path):
    """Issue 60: a fused --baseline lost its fusion without a word; a period read from time stamps near 1e6 s
    (0.30000001 s) was refused against the model's 0.3 s, and so was the advice's --resample 0.3."""
    from dataclasses import replace
    from pathlib import Path
    from thermoplc.base.errors import UserError
    from thermoplc.diagnosis import command
    from thermoplc.diagnosis.runs import DiagnoseRequest
    from thermoplc.models.modelfile import load_model
    from thermoplc.models.probing import Fusion
    lumped = load_model(str(Path(__file__).parent / "golden" / "lumped.json"))
    request = DiagnoseRequest(("x.csv",), tuple(s.column for s in lumped.signals("temperature")),
                              lumped.signals("speed")[0].column, lumped.signals("ambient")[0].column,
                              lumped.target.column)
    command._check_baseline(lumped, request, "lumped.json")
    fused = replace(lumped, probe=Fusion.of(0.5, 20.0, 100.0, 100.0))
    with pytest.raises(UserError, match="lumped.json: a fused model \\(fit --probe\\); diagnose .* give the model "
                                        "fitted without --probe"):
        command._check_baseline(fused, request, "lumped.json")
    at_03 = replace(lumped, sample_period_s=0.3)
    for start in (0.0, 1e6, 1.7e9):  # a logger's Unix time: each step rounded to the stamps' spacing
        dt = float(np.median(np.diff(start + 0.3 * np.arange(1000))))
        command.check_period(at_03, dt, "lumped.json")
    with pytest.raises(UserError, match="fitted at a sample period of 0.3 s; the data are sampled every 0.301 s"):
        command.check_period(at_03, 0.301, "lumped.json")


def test_a_file_url_standard_input_and_a_list_named_dash_are_inputs_too(folder, monkeypatch, capsys):
    """Hostile review of issue 60: `--data file:///...` and `--data - < run.csv` replaced the file read, and so
    did `-o ./-` over the list `--temps @-`."""
    import subprocess
    import sys
    monkeypatch.chdir(folder)
    before = {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}
    url = (folder / "run.csv").as_uri()
    for argv in ((*FIT, "--data", url, "-o", "run.csv", "--force"),
                 (*FIT, "--data", (folder / "camp").as_uri(), "-o", "camp/a.csv", "--force"),
                 (*VERIFY, "--data", url, "--outputs", "run.csv", "--force")):
        assert main(list(argv)) == 2, argv
        assert "is also an input of this command" in capsys.readouterr().err
    (folder / "-").write_text("T_motor\n")
    assert main(["fit", "--data", "run.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "@-", "--train-until",
                 "7200", "-o", "./-", "--force"]) == 2
    assert "is also an input of this command" in capsys.readouterr().err
    (folder / "-").unlink()
    with open(folder / "run.csv", "rb") as stdin:
        piped = subprocess.run([sys.executable, "-m", "thermoplc", *FIT, "--data", "-", "-o", "run.csv", "--force"],
                               stdin=stdin, capture_output=True, text=True, cwd=folder)
    assert piped.returncode == 2 and "run.csv: is also an input of this command" in piped.stderr
    assert {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()} == before
