"""The README as a tested contract: every command it shows after a `$ ` prompt runs as written, in
order, in one temporary folder, and every output line it shows is printed.

Lines are compared exactly, with two stated allowances: `...` in a shown output stands for any
number of omitted lines, and run-time measurements (seconds, calls or cycles per second) are
compared as numbers of any value, since they depend on the machine.
"""
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parent.parent / "README.md"
TIMING = re.compile(r"\d[\d,]*(?:\.\d+)?(?= (?:s\b|cycles/s|calls/s|M calls/s|MiB))")


def shown_sessions(text: str) -> list[tuple[str, list[str]]]:
    """(command, shown output lines) for every `$ ` line of every fenced block, in order."""
    sessions = []
    for block in re.findall(r"```\n(.*?)```", text, flags=re.S):
        lines = block.splitlines()
        if not lines or not lines[0].startswith("$ "):
            continue
        k = 0
        while k < len(lines):
            command = lines[k][2:]
            while command.endswith("\\"):
                k += 1
                command = command[:-1] + " " + lines[k].strip()
            k += 1
            output = []
            while k < len(lines) and not lines[k].startswith("$ "):
                output.append(lines[k])
                k += 1
            sessions.append((command, output))
    return sessions


def _masked(line: str) -> str:
    return TIMING.sub("#", line.rstrip())


def missing_lines(shown: list[str], printed: list[str]) -> list[str]:
    """Shown lines not printed in that order (`...` skips any number of printed lines)."""
    printed = [_masked(p) for p in printed]
    position, missing, skipping = 0, [], False
    for line in shown:
        if line.strip() == "...":
            skipping = True
            continue
        want = _masked(line)
        if skipping:
            found = next((j for j in range(position, len(printed)) if printed[j] == want), None)
        else:
            found = position if position < len(printed) and printed[position] == want else None
        if found is None:
            missing.append(line)
            continue
        position, skipping = found + 1, False
    return missing


def test_the_parser_of_the_readme_sees_the_walkthrough():
    commands = [c for c, _ in shown_sessions(README.read_text())]
    assert commands[0].startswith("thermoplc twin --hours 48 --seed 3")
    assert any(c.startswith("sed ") and "Edited.scl" in c for c in commands)
    assert missing_lines(["a", "...", "c"], ["a", "b", "c"]) == []
    assert missing_lines(["a", "c"], ["a", "b", "c"]) == ["c"]
    assert missing_lines(["replay: 0.01 s, 9 cycles/s"], ["replay: 2.50 s, 1,234 cycles/s"]) == []


@pytest.mark.slow  # the walkthrough fits, generates, verifies and diagnoses: a few minutes
def test_every_command_of_the_readme_prints_what_the_readme_shows(tmp_path):
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
           "SOURCE_DATE_EPOCH": "1767225600"}
    failures = []
    for command, shown in shown_sessions(README.read_text()):
        result = subprocess.run(["bash", "-c", command], cwd=tmp_path, env=env, capture_output=True, text=True,
                                stdin=subprocess.DEVNULL)
        if result.returncode not in (0, 1):  # 1: verify and diff report a difference, as the README shows
            failures.append(f"$ {command}\n  exit {result.returncode}: {result.stderr.strip()}")
            continue
        missing = missing_lines(shown, result.stdout.splitlines())
        if missing:
            failures.append(f"$ {command}\n  not printed:\n    " + "\n    ".join(missing)
                            + "\n  printed:\n    " + "\n    ".join(result.stdout.splitlines()[:40]))
    assert not failures, "\n".join(failures)
