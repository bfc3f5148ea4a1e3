"""Recordings in an object store (s3:// through pyarrow's filesystems), served here by moto's S3 server: read
as the same files are read from disk, by one process and by a cluster's workers, refused in one line when
they are not there."""
from __future__ import annotations

import json
import logging
import shutil

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from tests.golden_models import GOLDEN, golden_block, golden_twin_csv
from thermoplc.cli import main
from thermoplc.recordings.table import read_table

moto_server = pytest.importorskip("moto.server")
boto3 = pytest.importorskip("boto3")

BUCKET = "plant"
FIT = ("--target", "E_z_um", "--temps", "T_motor,T_bearing", "--folds", "4")


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """An S3 endpoint on this machine, a bucket holding the golden twin and a campaign folder (with its runs
    table); the local copies beside it."""
    logging.getLogger("werkzeug").setLevel(logging.ERROR)
    server = moto_server.ThreadedMotoServer(ip_address="127.0.0.1", port=0, verbose=False)
    server.start()
    host, port = server.get_host_and_port()
    environment = {"AWS_ACCESS_KEY_ID": "test", "AWS_SECRET_ACCESS_KEY": "test", "AWS_DEFAULT_REGION": "us-east-1",
                   "AWS_ENDPOINT_URL": f"http://{host}:{port}"}
    patch = pytest.MonkeyPatch()
    for key, value in environment.items():
        patch.setenv(key, value)
    folder = tmp_path_factory.mktemp("store")
    twin = golden_twin_csv(folder)
    assert main(["twin", "--runs", "4", "--hours", "4", "--dt", "120", "--seed", "5", "--probe-minutes", "0",
                 "-o", str(folder / "runs")]) == 0
    client = boto3.client("s3")
    client.create_bucket(Bucket=BUCKET)
    client.upload_file(str(twin), BUCKET, "twin.csv")
    columns = read_table(twin).columns
    np.savez(folder / "golden_twin.npz", **columns)
    pq.write_table(pa.table(columns), folder / "golden_twin.parquet")
    for suffix in ("npz", "parquet"):
        client.upload_file(str(folder / f"golden_twin.{suffix}"), BUCKET, f"twin.{suffix}")
    for run in sorted((folder / "runs").iterdir()):
        client.upload_file(str(run), BUCKET, f"campaign/{run.name}")
        if run.name != "runs.csv":
            client.upload_file(str(run), BUCKET, f"my runs/rün {run.name}")  # names as written, no %-encoding
        client.upload_file(str(run), BUCKET, f"decoy/{run.name}")
    client.put_object(Bucket=BUCKET, Key="decoy/old_runs.csv", Body=b"not,a,runs,table\n")
    client.put_object(Bucket=BUCKET, Key="tiny/bad.npz", Body=b"PK\x03\x04garbage")
    yield folder
    patch.undo()
    server.stop()


def _text(capsys, *argv) -> tuple[int, str]:
    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out + captured.err


@pytest.mark.parametrize("suffix", ["csv", "npz", "parquet"])
@pytest.mark.parametrize("route", ["whole", "streamed"])
def test_a_recording_in_the_store_verifies_as_its_file_does(store, capsys, monkeypatch, suffix, route):
    from tests.cli_runner import routes_taken
    if route == "streamed":
        monkeypatch.setattr("thermoplc.verifier.replays.stream.WHOLE_BELOW_BYTES", 0)
    taken = routes_taken(monkeypatch)
    block, model = str(golden_block("kalman", "tia")), str(GOLDEN / "kalman.json")
    local = _text(capsys, "verify", block, "--model", model, "--data", str(store / f"golden_twin.{suffix}"))
    remote = _text(capsys, "verify", block, "--model", model, "--data", f"s3://{BUCKET}/twin.{suffix}")
    assert local[0] == remote[0] == 0
    strip = lambda text: [line for line in text.splitlines()  # the timings differ
                          if not line.startswith("bit-exact") and "cycles/s" not in line]
    assert strip(local[1]) == strip(remote[1])
    assert len(taken) == 2 and all((seen == "streamed") == (route == "streamed") for seen in taken), taken


def test_a_campaign_in_the_store_is_read_through_its_runs_table(store, tmp_path):
    local, remote = tmp_path / "local.json", tmp_path / "remote.json"
    assert main(["fit", "--data", str(store / "runs"), "--model", "mlr", *FIT, "-o", str(local)]) == 0
    assert main(["fit", "--data", f"s3://{BUCKET}/campaign/", "--model", "mlr", *FIT, "-o", str(remote)]) == 0
    assert local.read_bytes() == remote.read_bytes()  # the same runs, attributes, names and bytes (sha256)


def test_a_campaign_in_the_store_fits_on_a_cluster_as_here(store, tmp_path):
    """The workers read the runs from the store themselves (they inherit its environment here)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=50) as cluster:
        here, there = tmp_path / "here.json", tmp_path / "there.json"
        options = ("--data", f"s3://{BUCKET}/campaign/", "--model", "dlag", *FIT)
        assert main(["fit", *options, "-o", str(here)]) == 0
        assert main(["fit", *options, "-o", str(there), "--scheduler", cluster.scheduler_address]) == 0
        assert here.read_bytes() == there.read_bytes()


def test_a_manifest_names_recordings_in_the_store(store, tmp_path, capsys):
    manifest = tmp_path / "fleet.csv"
    block, model = golden_block("mlr", "tia"), GOLDEN / "mlr.json"
    manifest.write_text(f"block,data,model\n{block},s3://{BUCKET}/twin.csv,{model}\n"
                        f"{block},s3://{BUCKET}/none.csv,{model}\n")
    code, text = _text(capsys, "verify", "--manifest", str(manifest))
    assert code == 2 and "1 bit-exact, 0 NOT bit-exact, 1 error" in text
    assert "s3://plant/none.csv: cannot read: no such file" in text


@pytest.mark.parametrize("url, expected", [
    (f"s3://{BUCKET}/missing.csv", "s3://plant/missing.csv: cannot read: no such file"),
    ("gopher://host/run.csv", "gopher://host/run.csv: cannot read: Unrecognized filesystem type in URI"),
    (f"s3://{BUCKET}/empty/", "s3://plant/empty/: cannot read: no such file"),
])
def test_what_the_store_cannot_give_is_one_line(store, capsys, url, expected):
    code, text = _text(capsys, "fit", "--data", url, "--model", "mlr", *FIT, "-o", "never.json")
    assert code == 2 and text.strip().splitlines() == [f"thermoplc: error: {expected}" + text.split(expected)[1]
                                                       .splitlines()[0]]


def test_a_local_folder_still_lists_as_before(store):
    """The object-store branch changes nothing for files: a copied folder lists the same recordings."""
    from thermoplc.recordings.campaign import run_list
    copy = store / "copy"
    shutil.copytree(store / "runs", copy, dirs_exist_ok=True)
    assert [p.rsplit("/", 1)[-1] for p in run_list([str(copy)], None).paths] == [
        p.name for p in sorted((store / "runs").glob("run_*.csv"))]


def test_names_with_spaces_and_letters_are_read_as_written(store, tmp_path):
    local, remote = tmp_path / "local.json", tmp_path / "remote.json"
    assert main(["fit", "--data", str(store / "runs"), "--model", "mlr", *FIT, "-o", str(local)]) == 0
    assert main(["fit", "--data", f"s3://{BUCKET}/my runs", "--model", "mlr", *FIT, "-o", str(remote)]) == 0
    model = json.loads(remote.read_text())
    assert [b["file"] for b in model["training"]["batches"]] == [f"rün run_00{k}.csv" for k in range(1, 5)]
    assert json.loads(local.read_text())["coefficients"] == model["coefficients"]


def test_a_query_is_no_part_of_the_name_or_the_format(store, capsys):
    block, model = str(golden_block("kalman", "tia")), str(GOLDEN / "kalman.json")
    code, text = _text(capsys, "verify", block, "--model", model, "--data",
                       f"s3://{BUCKET}/twin.parquet?region=us-east-1")
    assert code == 0 and "on twin.parquet" in text.splitlines()[0]


def test_a_folders_runs_table_is_the_one_named_runs_csv(store, tmp_path):
    out = tmp_path / "grouped.json"
    assert main(["fit", "--data", f"s3://{BUCKET}/decoy/", "--model", "mlr", "--target", "E_z_um", "--temps",
                 "T_motor,T_bearing", "--group-by", "hall", "-o", str(out)]) == 0


def test_a_broken_object_is_one_line_and_one_error_row(store, tmp_path, capsys):
    code, text = _text(capsys, "fit", "--data", f"s3://{BUCKET}/tiny/bad.npz", "--model", "mlr", *FIT,
                       "-o", str(tmp_path / "never.json"))
    assert code == 2 and text.strip().splitlines() == [
        f"thermoplc: error: s3://{BUCKET}/tiny/bad.npz: cannot read as .npz: File is not a zip file"]
    manifest = tmp_path / "fleet.csv"
    block, model = golden_block("mlr", "tia"), GOLDEN / "mlr.json"
    manifest.write_text(f"block,data,model\n{block},s3://{BUCKET}/twin.csv,{model}\n"
                        f"{block},s3://{BUCKET}/tiny/bad.npz,{model}\n")
    code, text = _text(capsys, "verify", "--manifest", str(manifest))
    assert code == 2 and "1 bit-exact, 0 NOT bit-exact, 1 error" in text and "Traceback" not in text


@pytest.mark.parametrize("option", ["-o", "--json", "--report"])
def test_an_output_named_by_a_url_is_refused(store, tmp_path, capsys, monkeypatch, option):
    monkeypatch.chdir(tmp_path)
    argv = ["fit", "--data", f"s3://{BUCKET}/twin.csv", "--model", "mlr", *FIT, "-o", str(tmp_path / "m.json")]
    argv += [option, f"s3://{BUCKET}/out"] if option != "-o" else []
    if option == "-o":
        argv[-1] = f"s3://{BUCKET}/m.json"
    code, text = _text(capsys, *argv)
    assert code == 2 and "object-store URLs are read, never written" in text
    assert not (tmp_path / "s3:").exists()
