"""Issue 48: every remote read and every cluster call is bounded. A store or a --scheduler that accepts and never
answers, or answers garbage, ends the command with one line within 30 s (exit 2, nothing written), and Ctrl-C
ends it within 1 s at any moment. The peers are fake servers on threads of this process; the CLI runs as a user
types it."""
from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import threading
import time
from pathlib import Path
from typing import Callable, Iterator

import pytest

from tests.cli_runner import CLI, thermoplc
from tests.golden_models import GOLDEN, golden_block, golden_twin_csv

pytest.importorskip("pyarrow.fs")

LIMIT_S = 30  # one line within this, whatever the peer does
CTRL_C_S = 1.0  # and Ctrl-C honoured within this
OBJECT_BYTES = 100_000_000  # what the half-answering store says its object has: read streamed, on a thread


@contextlib.contextmanager
def serving(answer: Callable[[socket.socket], None]) -> Iterator[tuple[int, threading.Event]]:
    """(port, an event set at the first connection) of a TCP server on 127.0.0.1 that hands every connection to
    `answer` on a thread of its own, the connections held open until the end."""
    listener = socket.create_server(("127.0.0.1", 0))
    held: list[socket.socket] = []
    connected = threading.Event()

    def accept() -> None:
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:  # closed at the end
                return
            held.append(conn)
            connected.set()
            threading.Thread(target=answer, args=(conn,), daemon=True).start()

    threading.Thread(target=accept, daemon=True).start()
    try:
        yield listener.getsockname()[1], connected
    finally:
        listener.shutdown(socket.SHUT_RDWR)
        listener.close()
        for conn in held:
            conn.close()


def never(conn: socket.socket) -> None:
    """Accept, then say nothing."""


def garbage(conn: socket.socket) -> None:
    """Bytes that are nobody's protocol (Dask reads its first frame's length from them: exabytes)."""
    with contextlib.suppress(OSError):
        conn.sendall(b"\xff" * 65536)


def answers_head_only(reading: threading.Event) -> Callable[[socket.socket], None]:
    """An S3 endpoint that answers HEAD (a large object) and never a GET; `reading` is set at the first GET."""
    def answer(conn: socket.socket) -> None:
        data = b""
        with contextlib.suppress(OSError):
            while chunk := conn.recv(65536):
                data += chunk
                while b"\r\n\r\n" in data:
                    head, data = data.split(b"\r\n\r\n", 1)
                    if not head.startswith(b"HEAD"):
                        reading.set()
                        return
                    conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: %d\r\nETag: \"x\"\r\n"
                                 b"Last-Modified: Wed, 01 Jan 2025 00:00:00 GMT\r\n\r\n" % OBJECT_BYTES)
    return answer


def s3_at(port: int) -> dict:
    return {"AWS_ENDPOINT_URL": f"http://127.0.0.1:{port}", "AWS_ACCESS_KEY_ID": "test",
            "AWS_SECRET_ACCESS_KEY": "test", "AWS_DEFAULT_REGION": "us-east-1", "AWS_EC2_METADATA_DISABLED": "true"}


def verify_data(url: str) -> tuple:
    return ("verify", golden_block("mlr", "tia"), "--model", GOLDEN / "mlr.json", "--data", url, "--json", "out.json")


def write_manifest(folder: Path) -> Path:
    """fleet.csv: one pair, its recording beside it."""
    data = golden_twin_csv(folder)
    path = folder / "fleet.csv"
    path.write_text(f"block,data,model\n{golden_block('mlr', 'tia')},{data.name},{GOLDEN / 'mlr.json'}\n")
    return path


@pytest.fixture
def manifest(tmp_path) -> Path:
    return write_manifest(tmp_path)


def one_line_in_time(folder: Path, *args, env: dict | None = None) -> str:
    """The one error line of the CLI run with `args`, asserted to come within LIMIT_S, with exit 2 and nothing
    written into `folder`."""
    before = sorted(folder.iterdir())
    start = time.monotonic()
    result = thermoplc(*args, cwd=folder, check=2, env=env, timeout=120)
    took = time.monotonic() - start
    lines = result.stderr.strip().splitlines()
    assert took < LIMIT_S and len(lines) == 1 and lines[0].startswith("thermoplc: error: "), (took, result.stderr)
    assert sorted(folder.iterdir()) == before and not result.stdout
    return lines[0]


@pytest.mark.parametrize("scheme", ["s3", pytest.param("gs", marks=pytest.mark.slow)])
def test_a_store_that_never_answers_is_one_line(tmp_path, scheme):
    with serving(never) as (port, _):
        url = (f"gs://anonymous@plant/run.csv?scheme=http&endpoint_override=127.0.0.1:{port}" if scheme == "gs"
               else "s3://plant/run.csv")
        line = one_line_in_time(tmp_path, *verify_data(url), env=s3_at(port))
    assert line == f"thermoplc: error: {url}: cannot read: no answer from the store within 20 s"


def test_a_scheduler_that_never_answers_is_one_line(manifest):
    with serving(never) as (port, _):
        line = one_line_in_time(manifest.parent, "verify", "--manifest", manifest.name, "--json", "out.json",
                                "--scheduler", f"tcp://127.0.0.1:{port}")
    assert f"--scheduler tcp://127.0.0.1:{port}: cannot reach a Dask scheduler there (no answer within 20 s)" in line


def test_a_scheduler_that_answers_garbage_is_one_line_and_no_traceback(manifest):
    start = time.monotonic()
    with serving(garbage) as (port, _):
        line = one_line_in_time(manifest.parent, "verify", "--manifest", manifest.name, "--json", "out.json",
                                "--scheduler", f"tcp://127.0.0.1:{port}")
    assert "cannot reach a Dask scheduler there (what answers there is not a Dask scheduler)" in line
    assert time.monotonic() - start < 10  # was 42 s, then a traceback from Client.__del__


def _store_never_answering(folder: Path, stack: contextlib.ExitStack) -> tuple[tuple, dict, threading.Event]:
    port, connected = stack.enter_context(serving(never))
    return verify_data("s3://plant/run.csv"), s3_at(port), connected


def _store_never_sending_the_bytes(folder: Path, stack: contextlib.ExitStack) -> tuple[tuple, dict, threading.Event]:
    reading = threading.Event()
    port, _ = stack.enter_context(serving(answers_head_only(reading)))
    return verify_data("s3://plant/run.csv")[:-2], s3_at(port), reading  # streamed: no --json


def _scheduler_never_answering(folder: Path, stack: contextlib.ExitStack) -> tuple[tuple, dict, threading.Event]:
    write_manifest(folder)
    port, connected = stack.enter_context(serving(never))
    return ("verify", "--manifest", "fleet.csv", "--scheduler", f"tcp://127.0.0.1:{port}"), {}, connected


@pytest.mark.parametrize("peer", [_store_never_answering, _store_never_sending_the_bytes, _scheduler_never_answering],
                         ids=["store-silent", "store-silent-mid-read", "scheduler-silent"])
def test_ctrl_c_while_waiting_for_a_peer_ends_the_command_at_once(tmp_path, peer):
    """SIGINT half a second after the peer was reached (the object's bytes asked for: by the thread that reads
    the next block ahead, which the main thread joins on its way out)."""
    with contextlib.ExitStack() as stack:
        args, env, waiting = peer(tmp_path, stack)
        before = sorted(tmp_path.iterdir())
        process = subprocess.Popen([*CLI, *map(str, args)], cwd=tmp_path, stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True,
                                   env={**os.environ, **env})
        assert waiting.wait(30), process.communicate(timeout=60)
        time.sleep(0.5)
        process.send_signal(signal.SIGINT)
        sent = time.monotonic()
        _, err = process.communicate(timeout=60)
        took = time.monotonic() - sent
    assert process.returncode == 130 and took < CTRL_C_S, (took, err)
    assert err.strip().splitlines() == ["thermoplc: interrupted; nothing half-written left behind"]
    assert sorted(tmp_path.iterdir()) == before
