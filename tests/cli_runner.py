"""The command line as a user runs it: `python -m thermoplc ...` in a child process, in a folder.

Every test that runs the CLI goes through `thermoplc`; a test that needs the process itself
(signals, a shell pipe, stdout onto a device) starts `CLI` with its own subprocess call.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

CLI = (sys.executable, "-m", "thermoplc")
# the progress a long command writes to a log (thermoplc/commands/terminal.py) depends on how loaded the
# machine is; tests/test_progress.py checks it, every other test reads what is left
PROGRESS_LINE = re.compile(r"^thermoplc: \d+ s: .*\n", re.MULTILINE)


def thermoplc(*args, cwd: Path, check: int | None = 0, stdin: str | None = None, env: dict | None = None,
              timeout: float | None = None) -> subprocess.CompletedProcess:
    """Run the CLI with `args` (each passed through str) in `cwd`, output captured as text.

    check: the exit code asserted (None: not checked). stdin: text fed to standard input (otherwise
    it is /dev/null). env: variables set on top of this process's environment.
    """
    result = subprocess.run([*CLI, *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=timeout,
                            input=stdin, stdin=subprocess.DEVNULL if stdin is None else None,
                            env=None if env is None else {**os.environ, **env})
    result.stderr = PROGRESS_LINE.sub("", result.stderr)
    if check is not None:
        assert result.returncode == check, result.stdout + result.stderr
    return result


def routes_taken(monkeypatch) -> list[str]:
    """The routes verify's streamed reading takes in this process from now on ("streamed", or "whole recording
    (why)"), noted by wrapping the library function the command calls."""
    from thermoplc.verifier.replays import stream
    taken: list[str] = []
    plain = stream.verify_streaming

    def noting(*args, **kwargs):
        streamed = plain(*args, **kwargs)
        taken.append(streamed.route)
        return streamed
    monkeypatch.setattr(stream, "verify_streaming", noting)
    return taken
