"""`verify --outputs FILE`: what the block output at each call, bit for bit what verify replayed."""
from __future__ import annotations

import numpy as np
import pyarrow.parquet as pq

from tests.cli_runner import thermoplc
from thermoplc.recordings.table import read_table


def _block(folder) -> None:
    thermoplc("twin", "--hours", "3", "--seed", "2", "-o", "data.csv", cwd=folder)
    thermoplc("fit", "--data", "data.csv", "--model", "dlag", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
              "--train-rows", "700", "-o", "m.json", cwd=folder)
    thermoplc("generate", "m.json", "-o", "b.scl", "--accept-unvalidated", cwd=folder)


def test_the_outputs_file_is_what_the_block_computed_to_the_bit(tmp_path):
    _block(tmp_path)
    verified = thermoplc("verify", "b.scl", "--model", "m.json", "--data", "data.csv", "--outputs", "out.csv",
                         cwd=tmp_path)
    assert "wrote out.csv: the block's" in verified.stdout
    out = read_table(str(tmp_path / "out.csv"))
    data = read_table(str(tmp_path / "data.csv"))
    assert list(out.columns)[:2] == ["time_s", "E_z_um"] and "Ready" in out.columns
    assert out.columns["time_s"].tobytes() == data.columns["time_s"].tobytes()
    written = [line.split(",") for line in (tmp_path / "out.csv").read_text().splitlines()]
    at = [written[0].index("E_z_um"), written[0].index("Ready")]

    def trace(values: list[str]) -> None:
        """The recording with the file's two outputs beside it, as a PLC trace would hold them."""
        rows = (tmp_path / "data.csv").read_text().splitlines()
        ready = [w[at[1]] for w in written[1:]]
        lines = [f"{rows[0]},plc_E_z_um,plc_Ready", *(f"{r},{v},{b}" for r, v, b in zip(rows[1:], values, ready))]
        (tmp_path / "trace.csv").write_text("\n".join(lines) + "\n")
    trace([w[at[0]] for w in written[1:]])
    expect = ("verify", "b.scl", "--expect", "E_z_um=plc_E_z_um,Ready=plc_Ready", "--data", "trace.csv")
    assert thermoplc(*expect, cwd=tmp_path).stdout.startswith("bit-exact")  # the trace of this file is the block
    bits = out.columns["E_z_um"].astype(np.float32).view(np.uint32).copy()
    bits[100] += 1  # one ULP off at one call
    trace([f"{float(v):.9g}" for v in bits.view(np.float32)])
    assert thermoplc(*expect, cwd=tmp_path, check=None).returncode == 1
    thermoplc("verify", "b.scl", "--model", "m.json", "--data", "data.csv", "--outputs", "out.parquet", cwd=tmp_path)
    table = pq.read_table(tmp_path / "out.parquet")
    assert str(table.schema.field("E_z_um").type) == "float" and str(table.schema.field("Ready").type) == "bool"
    parquet = table.column("E_z_um").to_numpy()
    assert parquet.view(np.uint32).tobytes() == out.columns["E_z_um"].astype(np.float32).view(np.uint32).tobytes()


def test_outputs_refused_where_there_is_no_one_replay_to_write(tmp_path):
    _block(tmp_path)
    base = ("verify", "b.scl", "--model", "m.json", "--data", "data.csv")
    cases = [((*base, "--outputs", "out.txt"), "expected a file ending in .csv or .parquet"),
             ((*base, "--outputs", "out.csv", "--faults"), "--outputs writes one replay's outputs"),
             ((*base, "--outputs", "data.csv", "--force"), "data.csv"),
             (("verify", "b.scl", "--model", "m.json", "--data", "data.csv", "--data", "data2.csv", "--outputs",
               "o.csv"), "--json, --faults and --outputs take one recording")]
    (tmp_path / "data2.csv").write_text((tmp_path / "data.csv").read_text())
    for argv, message in cases:
        result = thermoplc(*argv, cwd=tmp_path, check=None)
        assert result.returncode == 2 and message in result.stderr, (argv, result.stderr)
    assert not (tmp_path / "out.csv").exists() and not (tmp_path / "o.csv").exists()


def test_a_manifest_takes_no_outputs_and_a_trace_pair_no_resample(tmp_path):
    _block(tmp_path)
    (tmp_path / "m.csv").write_text("block,data,model\nb.scl,data.csv,m.json\n")
    refused = thermoplc("verify", "--manifest", "m.csv", "--outputs", "o.csv", cwd=tmp_path, check=2)
    assert "give no BLOCK, --data, --model, --expect, --faults or --outputs" in refused.stderr
    (tmp_path / "t.csv").write_text("block,expect,data\nb.scl,E_z_um=E_z_um,data.csv\n")
    traced = thermoplc("verify", "--manifest", "t.csv", "--resample", "10", cwd=tmp_path, check=None)
    assert traced.returncode == 2 and "a pair compared with a PLC trace" in traced.stdout + traced.stderr
