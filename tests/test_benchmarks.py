"""The papers' comparison script runs and fills every row (its numbers are in the README)."""
from benchmarks import papers


def test_papers_benchmark_fills_its_table(capsys):
    papers.ROWS.clear()
    papers.main()
    assert [r[0] for r in papers.ROWS] == ["000"] * 6 + ["001"] + ["002"] * 2 + ["003"] * 3 + ["004"]
    assert all(r[3] and "nan" not in r[3] for r in papers.ROWS)
