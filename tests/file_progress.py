"""One line per test file as soon as its last test has run: how many passed, failed or were
skipped, and the seconds its tests took (the sum of their durations; with two workers the wall
time is about half the total). Loaded by conftest.py; with xdist it runs in the controller, which
learns each file's test count from the workers' collection."""
from __future__ import annotations

from collections import Counter, defaultdict

import pytest


def _outcome(report) -> str | None:
    if report.failed:
        return "failed"
    if report.skipped:
        return "xfailed" if hasattr(report, "wasxfail") else "skipped"
    return None


class FileProgress:
    def __init__(self, reporter) -> None:
        self.reporter = reporter
        self.left: dict[str, int] = {}
        self.counts: dict[str, Counter] = defaultdict(Counter)
        self.seconds: dict[str, float] = defaultdict(float)
        self.test_outcome: dict[str, str] = {}

    def _count(self, node_ids) -> None:
        if not self.left:  # every worker collects the same tests; the first one says how many per file
            self.left = Counter(node_id.split("::")[0] for node_id in node_ids)

    @pytest.hookimpl(optionalhook=True)
    def pytest_xdist_node_collection_finished(self, node, ids) -> None:
        self._count(ids)

    def pytest_collection_finish(self, session) -> None:
        if not hasattr(session.config, "workerinput"):
            self._count(item.nodeid for item in session.items)

    def pytest_runtest_logreport(self, report) -> None:
        path = report.nodeid.split("::")[0]
        self.seconds[path] += report.duration
        outcome = _outcome(report)
        if outcome and self.test_outcome.get(report.nodeid) != "failed":
            self.test_outcome[report.nodeid] = outcome
        if report.when != "teardown":
            return
        self.counts[path][self.test_outcome.pop(report.nodeid, "passed")] += 1
        if path in self.left:
            self.left[path] -= 1
            if self.left[path] == 0:
                counts = ", ".join(f"{n} {outcome}" for outcome, n in sorted(self.counts[path].items()))
                if self.reporter._tw.width_of_current_line:  # after the progress dots
                    self.reporter._tw.line()
                self.reporter.write_line(f"{path}: {counts} in {self.seconds[path]:.1f} s")


@pytest.hookimpl(trylast=True)  # after the terminal reporter is registered
def pytest_configure(config) -> None:
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    if reporter is not None and not hasattr(config, "workerinput"):
        config.pluginmanager.register(FileProgress(reporter), "file-progress")
