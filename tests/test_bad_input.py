"""Every row of tests/bad_inputs.py, run as a user types it: one clear message and exit 2, or success.

The same runs render docs/bad_input.md; a stale table fails here (regenerate with
`python scripts/bad_input_table.py`).
"""
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from tests.bad_inputs import CASES, setup_folder, table_markdown
from tests.cli_runner import thermoplc

pytestmark = pytest.mark.slow  # the whole table: about two minutes of subprocesses

DOC = Path(__file__).resolve().parent.parent / "docs" / "bad_input.md"
OUTPUTS = ("out.json", "out.scl", "out.txt")


def run_all(base: Path, work: Path) -> list:
    def one(k_case):
        k, case = k_case
        folder = work / f"case{k:03d}"
        shutil.copytree(base, folder)
        case.prepare(folder)
        before = {name: (folder / name).exists() for name in OUTPUTS}
        return case, thermoplc(*case.argv, cwd=folder, check=None), folder, before
    with ThreadPoolExecutor(4) as pool:
        return list(pool.map(one, enumerate(CASES)))


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    base = tmp_path_factory.mktemp("base")
    setup_folder(base)
    return run_all(base, tmp_path_factory.mktemp("cases"))


@pytest.mark.parametrize("index", range(len(CASES)), ids=[f"{c.category}-{c.fault}-{c.command}" for c in CASES])
def test_bad_input_gets_one_clear_answer(results, index):
    case, result, folder, before = results[index]
    assert "Traceback" not in result.stderr
    if case.expect in ("accepted", "refused"):
        assert result.returncode == (0 if case.expect == "accepted" else 1), result.stdout + result.stderr
        assert case.message in result.stdout
        return
    assert result.returncode == 2, result.stdout + result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("thermoplc: error: "), result.stderr
    assert case.message in lines[0]
    for name in OUTPUTS:
        assert (folder / name).exists() == before[name], f"{name} was written although the command failed"


def test_the_documented_table_is_what_the_cases_give(results):
    rendered = table_markdown([(case, result) for case, result, _, _ in results])
    head = DOC.read_text().split("\n\n| input |", 1)[0] if DOC.exists() else ""
    assert DOC.exists() and DOC.read_text() == head + "\n\n" + rendered, \
        "docs/bad_input.md is stale: run python scripts/bad_input_table.py"
