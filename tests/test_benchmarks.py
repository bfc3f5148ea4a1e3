"""The papers' comparison script runs and fills every row (its numbers are in the README)."""
import pytest
from benchmarks import papers


@pytest.mark.slow
def test_papers_benchmark_fills_its_table(capsys, monkeypatch):
    monkeypatch.setattr(papers, "PAPER_002_SEEDS", 2)  # the table's shape, not the medians
    papers.ROWS.clear()
    papers.main()
    assert [r[0] for r in papers.ROWS] == ["000"] * 6 + ["001"] * 2 + ["002"] * 2 + ["003"] * 3 + ["004"] * 3
    assert all(r[3] and "nan" not in r[3] for r in papers.ROWS)


def test_replay_benchmark_reports_every_block_and_engine_as_json(capsys, monkeypatch):
    import json
    import sys
    from benchmarks import replay
    monkeypatch.setattr(sys, "argv", ["replay.py", "--cycles", "20000", "--interp-cycles", "300", "--json"])
    replay.main()
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert set(result) == {"mlr", "kalman", "piecewise", "dlag", "gm0n", "gm1n", "bayes", "bpnn", "lumped"}
    assert all(set(r) == {"interp", "fast", "c_plain", "reference"} and min(r.values()) > 0 for r in result.values())
