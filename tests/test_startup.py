"""What a short `verify` loads: neither lark's grammar builder nor numba (issue 40's start-up), and the
reference's compiled loops are taken once a process has asked for enough calls."""
from __future__ import annotations

import subprocess
import sys

import pytest

from tests.golden_models import GOLDEN, golden_block, golden_twin_csv
from thermoplc.base import compiled as kernels

PROBE = """
import sys
from thermoplc.cli import main
sys.argv = ["thermoplc", "verify", {block!r}, "--model", {model!r}, "--data", {data!r}]
code = main()
print("exit", code, "lark" in sys.modules, "numba" in sys.modules)
"""


@pytest.mark.parametrize("kind", ["kalman", "lumped"])
def test_a_short_verify_builds_no_grammar_and_loads_no_numba(tmp_path, kind):
    probe = PROBE.format(block=str(golden_block(kind, "tia")), model=str(GOLDEN / f"{kind}.json"),
                         data=str(golden_twin_csv(tmp_path)))
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, stdin=subprocess.DEVNULL)
    assert "bit-exact:" in result.stdout, result.stdout + result.stderr
    assert result.stdout.strip().splitlines()[-1] == "exit 0 False False"


def test_the_compiled_loops_are_taken_after_enough_calls(monkeypatch):
    if not kernels.available():
        pytest.skip("numba not installed")
    monkeypatch.setattr(kernels, "_asked", 0)
    with kernels.reference("auto"):
        assert not kernels.enabled(1000)
        assert kernels.enabled(kernels.COMPILED_AFTER_CALLS)
        assert kernels.enabled(1)
    monkeypatch.setattr(kernels, "_asked", 0)
    with kernels.reference("fast"):
        assert kernels.enabled(1)
    with kernels.reference("slow"):
        assert not kernels.enabled(kernels.COMPILED_AFTER_CALLS * 10)
