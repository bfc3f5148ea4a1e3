"""verify --manifest on a Dask distributed cluster (a local one here): the same JSON bytes as one process and
as --jobs, and a worker killed mid-pair loses no pair and doubles none."""
from __future__ import annotations

import contextlib
import os
import signal
import threading
import time

import pytest

from tests.golden_models import GOLDEN, golden_block, golden_twin_csv
from thermoplc.cli import main

distributed = pytest.importorskip("distributed")

KINDS = ("kalman", "mlr", "lumped", "gm1n")


def _local_cluster(workers: int):
    """A cluster of process workers on this machine, one thread each, quiet (no dashboard, no log lines)."""
    return distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                                    silence_logs=50)


@pytest.fixture(scope="module")
def cluster():
    with _local_cluster(2) as local:
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


def busy_workers(watcher, stop: threading.Event | None = None, seconds: float = 60) -> list[str]:
    """The addresses of the workers running a task, as soon as there are any (empty after `seconds` or `stop`)."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and not (stop and stop.is_set()):
        busy = [address for address, keys in watcher.processing().items() if keys]
        if busy:
            return busy
        time.sleep(0.02)
    return []


@contextlib.contextmanager
def killing_one_busy_worker(cluster):
    """SIGKILL the first worker seen busy, once; yields the list of killed pids."""
    watcher = distributed.Client(cluster.scheduler_address, set_as_default=False)
    killed, done = [], threading.Event()

    def kill_one_busy_worker():
        busy = busy_workers(watcher, stop=done)
        if busy:
            pid = watcher.run(os.getpid, workers=[busy[0]])[busy[0]]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    killer = threading.Thread(target=kill_one_busy_worker)
    killer.start()
    try:
        yield killed
    finally:
        done.set()
        killer.join()
        watcher.close()


def test_a_worker_killed_mid_pair_loses_nothing(cluster, manifest, tmp_path):
    serial = _run(manifest, tmp_path, "serial", "--engine", "interp")
    with killing_one_busy_worker(cluster) as killed:
        on_cluster = _run(manifest, tmp_path, "killed", "--engine", "interp", "--scheduler", cluster.scheduler_address)
    assert killed, "no worker was busy to kill"
    assert on_cluster == serial


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Four runs of 4 h at 60 s of the cascade machine, drift probed every 30 min and held."""
    folder = tmp_path_factory.mktemp("runs")
    assert main(["twin", "--runs", "4", "--hours", "4", "--dt", "60", "--seed", "5", "--probe-minutes", "30",
                 "-o", str(folder / "runs")]) == 0
    return folder / "runs"


FIT = ("--target", "E_z_um", "--temps", "T_motor,T_bearing,T_struct", "--speed", "n_rpm", "--ambient", "T_env",
       "--held-target")
GA = ("--generations", "4", "--population", "8")


def _fit(tmp_path, name: str, *options, report: bool = False) -> tuple:
    out, document, folder = tmp_path / f"{name}.json", tmp_path / f"{name}.fit.json", tmp_path / f"{name}-report"
    code = main(["fit", *options, "-o", str(out), "--json", str(document), *(("--report", str(folder)) if report else ())])
    drawn = {p.name: p.read_bytes().replace(str(out).encode(), b"OUT").replace(out.name.encode(), b"OUT")
             for p in sorted(folder.iterdir())} if report else {}
    return code, out.read_bytes(), document.read_bytes().replace(str(out).encode(), b"OUT"), drawn


@pytest.mark.parametrize("kind", ["kalman", "dlag"])
def test_a_campaigns_folds_on_a_cluster_give_the_model_file_of_one_process(cluster, runs, tmp_path, kind):
    roles = () if kind == "kalman" else ("--speed", "n_rpm", "--ambient", "T_env")  # dlag reads neither (issue 60)
    options = ("--data", str(runs), "--model", kind, *(a for a in FIT if a not in roles), *(GA if kind == "kalman" else ()),
               "--folds", "4")
    serial = _fit(tmp_path, "serial", *options, report=True)
    assert serial[0] == 0 and any(name.endswith(".png") for name in serial[3])
    assert serial == _fit(tmp_path, "dask", *options, "--scheduler", cluster.scheduler_address, report=True)


def test_a_recordings_blocks_and_auto_on_a_cluster_give_the_same_bits(cluster, tmp_path):
    data = str(golden_twin_csv(tmp_path))
    options = ("--data", data, "--target", "E_z_um", "--temps", "T_motor,T_bearing,T_struct", "--speed", "n_rpm",
               "--folds", "3")
    for kind in ("mlr", "auto"):
        serial = _fit(tmp_path, f"serial-{kind}", "--model", kind, *options)
        assert serial == _fit(tmp_path, f"dask-{kind}", "--model", kind, *options,
                              "--scheduler", cluster.scheduler_address)


def test_a_worker_killed_mid_fold_loses_nothing(cluster, runs, tmp_path):
    options = ("--data", str(runs), "--model", "kalman", *FIT, "--folds", "4", "--generations", "30", "--population", "8")
    serial = _fit(tmp_path, "serial", *options)
    with killing_one_busy_worker(cluster) as killed:
        on_cluster = _fit(tmp_path, "killed", *options, "--scheduler", cluster.scheduler_address)
    assert killed, "no worker was busy to kill"
    assert on_cluster == serial


def test_a_run_that_differs_where_a_worker_reads_it_is_refused(runs, tmp_path):
    from thermoplc.base.errors import UserError
    from thermoplc.recordings.campaign import read_campaign, run_list, source_of
    copy = tmp_path / "runs"
    copy.mkdir()
    for run in sorted(runs.glob("run_*.csv"))[:2]:
        (copy / run.name).write_bytes(run.read_bytes())
    listed = run_list([str(copy)], None)
    source = source_of(read_campaign(listed, "time_s"), listed, "time_s")
    assert [t.path for t in source.read().tables] == list(listed.paths)
    victim = copy / "run_002.csv"
    victim.write_bytes(victim.read_bytes().replace(b"\n", b"\r\n"))  # the same rows, other bytes
    from thermoplc.recordings import campaign
    campaign._LAST_READ.clear()
    with pytest.raises(UserError, match="run_002.csv: other bytes here .* every worker must read the same files"):
        source.read()


def test_a_worker_that_runs_other_code_is_refused_by_name():
    from thermoplc.base import cluster
    from thermoplc.base.errors import UserError
    theirs = tuple((name, "0.0" if name == "numpy" else value) for name, value in cluster.environment())
    with pytest.raises(UserError, match=r"worker tcp://10.0.0.9:1 does not run what this client runs \(numpy 0.0 "
                                        r"there, [0-9.]+ here\)"):
        cluster._same_environment(theirs, "tcp://10.0.0.9:1", "tcp://10.0.0.9:8786")
    cluster._same_environment(cluster.environment(), "tcp://10.0.0.9:1", "tcp://10.0.0.9:8786")


def test_a_scheduler_lost_mid_run_is_one_line_and_writes_nothing(manifest, tmp_path, capsys):
    local = _local_cluster(1)
    watcher = distributed.Client(local.scheduler_address, set_as_default=False)

    def close_when_busy():
        busy_workers(watcher)
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


def _diagnose(tmp_path, name: str, folder, *options) -> tuple[int, bytes, bytes]:
    out, findings = tmp_path / f"{name}.json", tmp_path / f"{name}.findings.json"
    code = main(["diagnose", "--data", str(folder), "--temps", "T_motor,T_bearing", "--speed", "n_rpm", "--ambient",
                 "T_env", "--target", "E_z_um", "-o", str(out), "--json", str(findings), *options])
    return code, out.read_bytes(), findings.read_bytes().replace(str(out).encode(), b"OUT")


def _twin_runs(folder, hours: int, *effect) -> str:
    assert main(["twin", "--runs", "4" if not effect else "5", "--hours", str(hours), "--dt", "120", "--seed", "3",
                 "--probe-minutes", "0", *effect, "-o", str(folder / "runs")]) == 0
    return folder / "runs"


def test_a_campaigns_diagnosis_on_a_cluster_gives_the_findings_of_one_process(cluster, tmp_path):
    runs = _twin_runs(tmp_path, 8)  # 7 h runs: the baseline extrapolates worse than none and nothing is tried
    serial = _diagnose(tmp_path, "serial", runs)
    assert serial[0] == 0 and b'"rejected_because"' in serial[2]  # candidates were fitted and judged
    assert serial == _diagnose(tmp_path, "dask", runs, "--scheduler", cluster.scheduler_address)


@pytest.mark.slow
def test_an_effect_named_on_a_cluster_is_named_with_the_same_bits(cluster, tmp_path):
    """The accepted path: the named effect's fit comes back from a worker, its residuals are rebuilt here."""
    runs = _twin_runs(tmp_path, 8, "--effect", "gear_ratio_switch:threshold_rpm=750")
    serial = _diagnose(tmp_path, "serial", runs)
    assert b'"name": "gear_ratio_switch"' in serial[2]
    assert serial == _diagnose(tmp_path, "dask", runs, "--scheduler", cluster.scheduler_address)


def test_auto_stops_on_a_cluster_refusal_instead_of_skipping_the_candidate(monkeypatch, tmp_path):
    """A fold the cluster lost (or a worker that runs other code, or reads other bytes) is no candidate that
    could not be fitted: the ranking would quietly differ from one process's."""
    from thermoplc.base.errors import ClusterError
    from thermoplc.fitting import auto, crossval
    from thermoplc.fitting.fit import FitRequest
    from thermoplc.recordings.table import read_table

    def lost(*args, **kwargs):
        raise ClusterError("--scheduler tcp://10.0.0.9:8786: the cluster lost fold 2")
    monkeypatch.setattr(crossval, "fit_held_out", lost)
    table = read_table(golden_twin_csv(tmp_path))
    with pytest.raises(ClusterError, match="the cluster lost fold 2"):
        auto.rank([table], FitRequest("auto", "E_z_um", ("T_motor", "T_bearing")), 3, "time_s")


@pytest.mark.slow
def test_a_cluster_whose_workers_all_leave_ends_the_command_in_one_line(runs, tmp_path, capsys):
    local = _local_cluster(1)
    watcher = distributed.Client(local.scheduler_address, set_as_default=False)

    def retire_when_busy():
        busy_workers(watcher)
        local.scale(0)  # the workers leave for good; the scheduler stays

    leaver = threading.Thread(target=retire_when_busy)
    leaver.start()
    try:
        out = tmp_path / "never.json"
        started = time.monotonic()
        code = main(["fit", "--data", str(runs), "--model", "kalman", *FIT, "--folds", "4", "--generations", "200",
                     "--population", "8", "-o", str(out), "--scheduler", local.scheduler_address])
        error = capsys.readouterr().err.strip().splitlines()
    finally:
        leaver.join()
        watcher.close()
        local.close()
    assert code == 2 and not out.exists() and time.monotonic() - started < 120
    assert "no worker left for 20 s" in error[-1] and "nothing written" in error[-1]


def _one_ulp_up(block: str) -> str:
    """The block with its first REAL constant one ULP larger."""
    import re
    import numpy as np
    match = re.search(r"(c_beta0 : Real := )([-0-9.E]+);", block)
    bigger = np.nextafter(np.float32(match.group(2)), np.float32(np.inf))
    return block.replace(match.group(0), f"{match.group(1)}{np.format_float_positional(bigger, unique=True)};", 1)


def test_a_campaign_verified_by_a_worker_in_another_folder_judges_the_users_files(tmp_path, monkeypatch):
    """Issue 48: the worker's folder holds the good block, the user's folder one a ULP off; the cluster's verdict
    must be the user's block's, as without --scheduler."""
    import shutil
    import subprocess
    import sys
    worker_folder, user_folder = tmp_path / "worker", tmp_path / "user"
    for folder in (worker_folder, user_folder):
        folder.mkdir()
        shutil.copy(golden_block("mlr", "tia"), folder / "mlr.scl")
        shutil.copy(GOLDEN / "mlr.json", folder / "mlr.json")
        golden_twin_csv(folder).rename(folder / "twin.csv")
    edited = _one_ulp_up((user_folder / "mlr.scl").read_text())
    assert edited != (user_folder / "mlr.scl").read_text()
    (user_folder / "mlr.scl").write_text(edited)
    argv = ["verify", "mlr.scl", "--model", "mlr.json", "--data", "twin.csv", "--data", "twin.csv", "--engine", "interp"]
    with distributed.LocalCluster(n_workers=0, processes=True, dashboard_address=None, silence_logs=50) as local:
        worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", local.scheduler_address,
                                   "--nthreads", "1", "--no-dashboard"], cwd=worker_folder,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            monkeypatch.chdir(user_folder)
            alone = main(argv)
            on_cluster = main([*argv, "--scheduler", local.scheduler_address])
        finally:
            worker.terminate()
            worker.wait(30)
    assert alone == on_cluster == 1


def test_a_pair_whose_file_has_other_bytes_where_it_runs_fails(tmp_path):
    from dataclasses import replace
    from thermoplc.verifier.fleets.fleet_dask import pinned
    from thermoplc.verifier.fleets.pair import Pair, verify_pair
    block = tmp_path / "mlr.scl"
    block.write_bytes(golden_block("mlr", "tia").read_bytes())
    pair = pinned(Pair(1, str(block), str(golden_twin_csv(tmp_path)), str(GOLDEN / "mlr.json"), None, None))
    assert {path for path, _ in pair.sha256} == {pair.block, pair.data, pair.model}
    assert verify_pair(pair, "interp").status == "bit-exact"
    block.write_text(_one_ulp_up(block.read_text()))
    outcome = verify_pair(pair, "interp")
    assert outcome.status == "error" and "mlr.scl: other bytes where this pair ran" in outcome.detail
    assert verify_pair(replace(pair, sha256=()), "interp").status == "NOT bit-exact"
