"""What long commands tell the user beside their result: progress in a log, the next commands to run."""
from __future__ import annotations

import io

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
