"""What long commands tell the user beside their result: progress in a log, the next commands to run."""
from __future__ import annotations

import io
import re
import signal
import subprocess
from pathlib import Path

import pytest

from tests.cli_runner import CLI, thermoplc
from thermoplc.commands import terminal


def test_a_log_gets_a_timed_line_every_few_seconds_and_no_carriage_return(monkeypatch):
    clock = iter([100.0, 101.0, 104.0, 105.5, 107.0, 111.0])
    monkeypatch.setattr(terminal.time, "monotonic", lambda: next(clock))
    err = io.StringIO()
    monkeypatch.setattr(terminal.sys, "stderr", err)
    say = terminal.progress()  # StringIO is not a terminal
    for message in ("reading", "generation 1/40", "generation 2/40", "generation 3/40", "generation 4/40"):
        say(message)
    assert err.getvalue() == "thermoplc: 6 s: generation 2/40\nthermoplc: 11 s: generation 4/40\n"


def test_a_short_command_writes_nothing_to_a_log(monkeypatch):
    clock = iter([0.0, 0.5, 1.0, 4.9])
    monkeypatch.setattr(terminal.time, "monotonic", lambda: next(clock))
    err = io.StringIO()
    monkeypatch.setattr(terminal.sys, "stderr", err)
    say = terminal.progress()
    for message in ("a", "b", "c"):
        say(message)
    terminal.end_progress()
    assert err.getvalue() == ""


def test_diagnose_says_what_to_run_next_as_a_user_types_it():
    from thermoplc.diagnosis.findings import next_steps
    doc = {"model": "runs/diag model.json", "data": {"file": "hall 3.csv"}}
    assert next_steps(doc) == ["thermoplc generate 'runs/diag model.json' -o 'runs/diag model.scl'",
                               "thermoplc verify 'runs/diag model.scl' --model 'runs/diag model.json' --data 'hall 3.csv'"]
    assert next_steps({"model": None, "data": {}}) == []


def test_a_next_command_never_reads_a_path_as_an_option():
    from thermoplc.diagnosis.findings import next_steps
    steps = next_steps({"model": "-d m.json", "data": {"file": "-x.csv"}})
    assert steps == ["thermoplc generate './-d m.json' -o './-d m.scl'",
                     "thermoplc verify './-d m.scl' --model './-d m.json' --data ./-x.csv"]


def _fit_bpnn_with_huge_caps(folder: Path) -> subprocess.Popen:
    """bpnn at 10,000 x 10,000 (about two hours here), started as a script starts a background job:
    with SIGINT ignored, so only thermoplc's own handling can make an interrupt stop it."""
    return subprocess.Popen([*CLI, "fit", "--data", "t.csv", "--model", "bpnn", "--target", "E_z_um", "--temps",
                             "T_motor,T_bearing", "--train-rows", "400", "--population", "10000", "--generations",
                             "10000", "-o", "big.json"], cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            stdin=subprocess.DEVNULL, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))


@pytest.mark.parametrize("stop, code, said", [(signal.SIGINT, 130, "interrupted"),
                                              pytest.param(signal.SIGTERM, 143, "terminated", marks=pytest.mark.slow)])
def test_a_long_bpnn_fit_reports_an_estimate_and_stops_cleanly(tmp_path, stop, code, said):
    """Issue 38 item 5: bpnn at large caps printed nothing for hours; every long fit reports its steps with
    the time left and stops on SIGINT or SIGTERM, nothing written."""
    thermoplc("twin", "--hours", 2, "--seed", 3, "-o", "t.csv", cwd=tmp_path)
    process = _fit_bpnn_with_huge_caps(tmp_path)
    lines = []
    for line in process.stderr:
        lines.append(line)
        if re.search(r"bpnn 2/4 weights of \d+ hidden neurons: generation \d+/10000, best SSE \S+, about \d+ s left",
                     line):
            break
    process.send_signal(stop)
    _, rest = process.communicate(timeout=60)
    assert process.returncode == code and said in rest and "Traceback" not in rest, "".join(lines) + rest
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.csv"]


def test_no_next_steps_after_data_that_could_not_decide():
    """A model the data could not judge is written, but no block is offered to prove (generate refuses it)."""
    from thermoplc.diagnosis.findings import next_steps
    assert next_steps({"model": "m.json", "data": {"file": "x.csv"}, "verdict": "insufficient_data"}) == []
    assert next_steps({"model": "m.json", "data": {"file": "x.csv"}, "verdict": "unexplained"}) != []
