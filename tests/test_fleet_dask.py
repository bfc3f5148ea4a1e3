"""verify --manifest on a Dask distributed cluster (a local one here): the same JSON bytes as one process and
as --jobs, and a worker killed mid-pair loses no pair and doubles none."""
from __future__ import annotations

import os
import signal
import threading
import time

import pytest

from tests.golden_models import GOLDEN, golden_block, golden_twin_csv
from thermoplc.cli import main

distributed = pytest.importorskip("distributed")

KINDS = ("kalman", "mlr", "lumped", "gm1n")


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=50) as local:
        yield local


@pytest.fixture(scope="module")
def manifest(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fleet")
    data = golden_twin_csv(folder)
    rows = ["block,data,model"] + [f"{golden_block(kind, 'tia')},{data},{GOLDEN / f'{kind}.json'}"
                                   for _ in range(2) for kind in KINDS]
    rows.append(f"{golden_block('kalman', 'tia')},{data},{GOLDEN / 'mlr.json'}")  # a pair that does not match
    path = folder / "fleet.csv"
    path.write_text("\n".join(rows) + "\n")
    return path




def _run(manifest, tmp_path, name: str, *options) -> tuple[int, bytes]:
    out = tmp_path / f"{name}.json"
    code = main(["verify", "--manifest", str(manifest), *options, "--json", str(out)])
    return code, out.read_bytes()


def test_a_cluster_gives_the_bytes_of_one_process_and_of_jobs(cluster, manifest, tmp_path):
    serial = _run(manifest, tmp_path, "serial")
    assert serial == _run(manifest, tmp_path, "jobs", "--jobs", "2")
    assert serial == _run(manifest, tmp_path, "dask", "--scheduler", cluster.scheduler_address)
    assert b'"NOT bit-exact"' in serial[1] or b'"error"' in serial[1]


def test_a_worker_killed_mid_pair_loses_nothing(cluster, manifest, tmp_path):
    serial = _run(manifest, tmp_path, "serial", "--engine", "interp")
    watcher = distributed.Client(cluster.scheduler_address, set_as_default=False)
    killed = []

    def kill_one_busy_worker():
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not killed:
            busy = [address for address, keys in watcher.processing().items() if keys]
            if busy:
                pid = watcher.run(os.getpid, workers=[busy[0]])[busy[0]]
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
            time.sleep(0.02)

    killer = threading.Thread(target=kill_one_busy_worker)
    killer.start()
    try:
        on_cluster = _run(manifest, tmp_path, "killed", "--engine", "interp", "--scheduler", cluster.scheduler_address)
    finally:
        killer.join()
        watcher.close()
    assert killed, "no worker was busy to kill"
    assert on_cluster == serial


def test_a_scheduler_lost_mid_run_is_one_line_and_writes_nothing(manifest, tmp_path, capsys):
    local = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                                     silence_logs=50)
    watcher = distributed.Client(local.scheduler_address, set_as_default=False)

    def close_when_busy():
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if any(watcher.processing().values()):
                break
            time.sleep(0.02)
        watcher.close()
        local.close()

    closer = threading.Thread(target=close_when_busy)
    closer.start()
    out = tmp_path / "lost.json"
    code = main(["verify", "--manifest", str(manifest), "--engine", "interp", "--scheduler", local.scheduler_address,
                 "--json", str(out)])
    closer.join()
    error = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and not out.exists()
    assert len(error) == 1 and "the cluster lost the pair of manifest line" in error[0] and "nothing written" in error[0]


def test_an_address_nothing_answers_at_is_one_line_at_once(manifest, capsys):
    import socket
    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    started = time.monotonic()
    code = main(["verify", "--manifest", str(manifest), "--scheduler", f"tcp://127.0.0.1:{port}"])
    error = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and time.monotonic() - started < 10
    assert len(error) == 1 and "cannot reach a Dask scheduler there" in error[0]
