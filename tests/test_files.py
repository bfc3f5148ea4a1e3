"""Issue 15: outputs never destroy a user's file. One overwrite rule, modes that follow the umask or
the replaced file, all-or-nothing writes, and no temporary file left by SIGTERM or Ctrl-C."""
import os
import shlex
import signal
import subprocess
import time
from pathlib import Path

import pytest

from tests.cli_runner import CLI, thermoplc
from tests.golden_models import GOLDEN
from thermoplc.base.errors import UserError
from thermoplc.base.fileio import check_output, check_outputs, check_report_folder, report_manifest, write_outputs


def test_new_files_follow_the_umask_and_replaced_files_keep_their_mode(tmp_path):
    old = os.umask(0o027)
    try:
        write_outputs([(tmp_path / "new.txt", "a")])
        assert (tmp_path / "new.txt").stat().st_mode & 0o777 == 0o640
        (tmp_path / "kept.txt").write_text("old")
        os.chmod(tmp_path / "kept.txt", 0o604)
        write_outputs([(tmp_path / "kept.txt", "new")])
        assert (tmp_path / "kept.txt").stat().st_mode & 0o777 == 0o604 and (tmp_path / "kept.txt").read_text() == "new"
    finally:
        os.umask(old)


def test_a_failed_write_changes_no_output_and_leaves_no_temporary_file(tmp_path):
    (tmp_path / "a.txt").write_text("old a")
    with pytest.raises(UserError, match="nothing written"):
        write_outputs([(tmp_path / "a.txt", "new a"), (tmp_path / "a.txt" / "b.txt", "b")])  # b's folder is a file
    assert (tmp_path / "a.txt").read_text() == "old a"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_sigterm_while_writing_removes_the_temporary_files(tmp_path, monkeypatch):
    from thermoplc.cli import Terminated, _terminate
    previous = signal.signal(signal.SIGTERM, _terminate)
    real_fsync = os.fsync

    def fsync_then_terminated(fd):
        real_fsync(fd)
        os.kill(os.getpid(), signal.SIGTERM)
    monkeypatch.setattr(os, "fsync", fsync_then_terminated)
    try:
        with pytest.raises(Terminated):
            write_outputs([(tmp_path / "a.txt", "a" * 1000), (tmp_path / "b.txt", "b")])
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert list(tmp_path.iterdir()) == []


def test_sigterm_during_a_long_twin_run_leaves_nothing_half_written(tmp_path):
    for delay in (0.5, 2.0):
        process = subprocess.Popen([*CLI, "twin", "--hours", "3000", "-o", "big.csv"], cwd=tmp_path,
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)
        time.sleep(delay)
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=120)
        leftovers = [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
        assert leftovers == [] and "Traceback" not in err
        if process.returncode == 143:
            assert not (tmp_path / "big.csv").exists() and "terminated" in err
        else:
            assert process.returncode == 0 and (tmp_path / "big.csv").exists()
            (tmp_path / "big.csv").unlink()


def test_ctrl_c_ends_quietly_with_130(tmp_path):
    process = subprocess.Popen([*CLI, "twin", "--hours", "3000", "-o", "big.csv"], cwd=tmp_path,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)
    # Ctrl-C while the command works, not while the interpreter itself starts (on a loaded machine that
    # takes seconds): wait until the process has loaded numpy, which the CLI imports inside its handling
    maps = Path(f"/proc/{process.pid}/maps")
    deadline = time.monotonic() + 60
    while process.poll() is None and time.monotonic() < deadline and "_multiarray_umath" not in maps.read_text():
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 130 and "Traceback" not in err and "interrupted" in err
    assert [p.name for p in tmp_path.iterdir()] == []


def test_a_closed_pipe_and_a_full_disk_end_without_a_traceback(tmp_path):
    piped = subprocess.run(f"{shlex.join(CLI)} --help | head -1", shell=True, cwd=tmp_path,
                           capture_output=True, text=True)
    assert "Traceback" not in piped.stderr
    with open("/dev/full", "w") as full:
        result = subprocess.run([*CLI, "twin", "--hours", "1", "-o", "t.csv"], cwd=tmp_path, stdout=full,
                                stderr=subprocess.PIPE, text=True)
    assert result.returncode == 2 and "standard output: No space left on device" in result.stderr
    assert "Traceback" not in result.stderr
    closed = subprocess.run(f"{shlex.join(CLI)} twin --hours 1 -o closed.csv >&-", shell=True, cwd=tmp_path,
                            capture_output=True, text=True)  # started with no standard output at all
    assert closed.returncode == 0 and "Traceback" not in closed.stderr and (tmp_path / "closed.csv").exists()


def test_the_report_folder_rule(tmp_path):
    names = ["channel_1.png", "index.html"]
    assert check_report_folder(tmp_path / "new", names) == []
    (tmp_path / "empty").mkdir()
    assert check_report_folder(tmp_path / "empty", names) == []
    own = tmp_path / "own"
    own.mkdir()
    written = [(name, f"{name} as written") for name in ("channel_1.png", "channel_2.png", "index.html")]
    (own / ".thermoplc-report").write_text(report_manifest(written))
    for name, text in [*written, ("notes.txt", "mine")]:
        (own / name).write_text(text)
    from thermoplc.diagnosis.report import is_report_file
    assert check_report_folder(own, names, recognised=is_report_file) == ["channel_2.png"]  # stale, its own: removed
    assert check_report_folder(own, names) == []  # nothing recognised as a report's own: nothing removed
    with pytest.raises(UserError, match="notes.txt exists and is not listed"):
        check_report_folder(own, [*names, "notes.txt"])
    manifest = (own / ".thermoplc-report").read_text()
    (own / ".thermoplc-report").write_text(manifest + "notes.txt\n")  # tampered: a name without its digest
    assert check_report_folder(own, names, recognised=is_report_file) == ["channel_2.png"]  # notes.txt stays
    (own / "channel_2.png").write_text("the user's own picture, put where a report's was")
    assert check_report_folder(own, names, recognised=is_report_file) == []  # changed since written: stays
    (own / "index.html").write_text("edited by hand")
    with pytest.raises(UserError, match="index.html exists and was changed since thermoplc wrote it"):
        check_report_folder(own, names, recognised=is_report_file)


def test_no_output_inside_the_report_folder_nor_onto_another(tmp_path):
    inputs = [str(tmp_path / "data.csv")]
    with pytest.raises(UserError, match="rep/index.html: is inside the --report folder"):
        check_outputs({"-o": str(tmp_path / "rep/index.html")}, False, inputs, str(tmp_path / "rep"), ["index.html"])
    with pytest.raises(UserError, match="rep/deeper/m.json: is inside the --report folder"):
        check_outputs({"-o": str(tmp_path / "m.json"), "--json": str(tmp_path / "rep/deeper/m.json")}, False, inputs,
                      str(tmp_path / "rep"))
    with pytest.raises(UserError, match="named for both -o and --json"):
        check_outputs({"-o": str(tmp_path / "m.json"), "--json": str(tmp_path / "./m.json")}, False, inputs)
    with pytest.raises(UserError, match="holds .*data.csv, an input of this command"):
        check_outputs({"-o": str(tmp_path / "m.json")}, False, [str(tmp_path / "runs/data.csv")], str(tmp_path / "runs"))
    with pytest.raises(UserError, match="--report '': an empty name"):
        check_outputs({"-o": str(tmp_path / "m.json")}, False, inputs, "")
    assert check_outputs({"-o": str(tmp_path / "m.json")}, False, inputs, str(tmp_path / "rep"), ["index.html"]) == []


def test_a_fit_report_never_deletes_a_file_it_did_not_write(tmp_path):
    """Issue 48: a model written as rep/run_004.png beside a 4-run report was deleted by a later 3-run report."""
    run = lambda *a: thermoplc(*a, cwd=tmp_path, check=None)
    assert run("twin", "--runs", "4", "--hours", "2", "--dt", "60", "--seed", "5", "-o", "runs").returncode == 0
    fit = ("fit", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor,T_bearing", "--folds", "3")
    refused = run(*fit, "--data", "runs", "--report", "rep", "-o", "rep/run_004.png")
    assert refused.returncode == 2 and "rep/run_004.png: is inside the --report folder rep" in refused.stderr
    assert not (tmp_path / "rep").exists()
    assert run(*fit, "--data", "runs", "--report", "rep", "-o", "m.json").returncode == 0
    (tmp_path / "rep" / "run_004.png").write_text("the user's model, written there by hand")
    runs = sorted(str(p) for p in (tmp_path / "runs").glob("*.csv"))[:3]
    again = run(*fit, *(a for r in runs for a in ("--data", r)), "--report", "rep", "-o", "m2.json")
    assert again.returncode == 0, again.stderr
    assert (tmp_path / "rep" / "run_004.png").read_text() == "the user's model, written there by hand"


def test_outputs_onto_inputs_are_refused_even_through_another_path(tmp_path):
    (tmp_path / "data.csv").write_text("x")
    os.link(tmp_path / "data.csv", tmp_path / "hard.csv")
    for name in ("data.csv", "./data.csv", "hard.csv"):
        with pytest.raises(UserError, match="is also an input"):
            check_output(tmp_path / name, True, inputs=[tmp_path / "data.csv"])


def test_diagnose_report_is_replaced_only_in_its_own_files(tmp_path):
    run = lambda *a: thermoplc(*a, cwd=tmp_path, check=None)
    assert run("twin", "--hours", "6", "--seed", "2", "-o", "t.csv").returncode == 0
    diagnose = ("diagnose", "--data", "t.csv", "--speed", "n_rpm", "--ambient", "T_env", "--temps", "T_motor",
                "--target", "E_z_um", "--train-rows", "1500", "--report", "rep", "--json", "f.json", "-o", "m.json")
    first = run(*diagnose)
    assert first.returncode == 0, first.stderr
    (tmp_path / "rep" / "notes.txt").write_text("mine")
    manifest = tmp_path / "rep" / ".thermoplc-report"
    manifest.write_text(manifest.read_text() + "notes.txt\n")  # a hand-edited index must not make it ours
    again = run(*diagnose, "--force")
    assert again.returncode == 0, again.stderr
    assert (tmp_path / "rep" / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in (tmp_path / "rep").iterdir()) == [
        ".thermoplc-report", "channel_1.png", "channel_2.png", "index.html", "notes.txt"]


LOOP_BLOCK = """FUNCTION_BLOCK Loop
VAR_INPUT x : REAL; END_VAR
VAR_OUTPUT y : REAL; END_VAR
VAR i : DINT; acc : REAL; END_VAR
VAR CONSTANT c_tiny : REAL := 1.0E-39; c_zero : REAL := 0.0; END_VAR
acc := c_zero;
FOR i := 0 TO 999 DO
  acc := acc + c_tiny;
END_FOR;
y := x;
END_FUNCTION_BLOCK
"""


def test_the_interpreter_has_a_budget_for_the_whole_replay(tmp_path, monkeypatch, capsys):
    import numpy as np
    from thermoplc.cli import main
    from thermoplc.recordings.table import write_table
    from thermoplc.verifier.engines import interpreter
    monkeypatch.setattr(interpreter, "MAX_REPLAY_LOOP_ITERATIONS", 20_000)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "loop.st").write_text(LOOP_BLOCK)
    (tmp_path / "d.csv").write_text(write_table({"time_s": np.arange(100) * 10.0, "x": np.ones(100),
                                                 "y_plc": np.ones(100)}))
    assert main(["verify", "loop.st", "--data", "d.csv", "--expect", "y=y_plc", "--engine", "interp"]) == 2
    assert "FOR loops of this replay exceed 20,000 iterations" in capsys.readouterr().err


def test_a_dash_is_standard_input_or_output_where_one_stream_makes_sense(tmp_path):
    """Issue 28 item 8: `-o -` and `--data -` named files called '-'."""
    golden = GOLDEN / "mlr.json"
    run = lambda *a, stdin=None: thermoplc(*a, cwd=tmp_path, check=None, stdin=stdin)
    block = run("generate", golden, "-o", "-")
    assert block.returncode == 0 and block.stdout.startswith('FUNCTION_BLOCK "ThermalComp"')
    assert block.stderr.startswith("wrote standard output: mlr block") and not (tmp_path / "-").exists()
    assert run("twin", "--hours", "2", "--seed", "3", "-o", "t.csv").returncode == 0
    (tmp_path / "b.scl").write_text(block.stdout)
    verified = run("verify", "b.scl", "--model", golden, "--data", "-", stdin=(tmp_path / "t.csv").read_text())
    assert verified.returncode == 0 and "reproduces the float32 reference of mlr.json (mlr) on <stdin>" in verified.stdout
    fitted = run("fit", "--data", "t.csv", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor",
                 "--train-rows", "300", "-o", "-")
    assert fitted.returncode == 2 and "-o -: this command writes a file" in fitted.stderr
    assert not (tmp_path / "-").exists()


def test_a_dash_is_standard_input_on_every_path_even_beside_a_file_named_dash(tmp_path):
    """Issue 38 item 2: with a file called '-' in the folder, `--data -` streamed that file on one path and
    read standard input on another; `--data - --data -` ended in a traceback."""
    golden = GOLDEN / "mlr.json"
    run = lambda *a, stdin=None: thermoplc(*a, cwd=tmp_path, check=None, stdin=stdin)
    assert run("twin", "--hours", "6", "--seed", "3", "-o", "t.csv").returncode == 0
    text = (tmp_path / "t.csv").read_text()
    calls = len(text.splitlines()) - 1
    (tmp_path / "-").write_text("\n".join(text.splitlines()[:50]) + "\n")
    assert run("generate", golden, "-o", "b.scl").returncode == 0
    for engine in ("fast", "interp"):
        verified = run("verify", "b.scl", "--model", golden, "--data", "-", "--engine", engine, stdin=text)
        assert verified.returncode == 0 and f"{calls} cycles" in verified.stdout, verified.stdout + verified.stderr
    differ = run("diff", "b.scl", "b.scl", "--data", "-", stdin=text)
    assert differ.returncode == 0 and f"({calls} calls)" in differ.stdout, differ.stdout + differ.stderr
    fitted = run("fit", "--data", "-", "--model", "mlr", "--target", "E_z_um", "--temps", "T_motor",
                 "--train-rows", "1000", "-o", "m.json", stdin=text)
    assert fitted.returncode == 0 and f"{calls - 1000} held out" in fitted.stdout, fitted.stdout + fitted.stderr
    twice = run("verify", "b.scl", "--model", golden, "--data", "-", "--data", "-", stdin=text)
    assert twice.returncode == 2 and twice.stderr.strip().splitlines() == [
        "thermoplc: error: --data -: standard input can be read once; give the other runs as files"]
