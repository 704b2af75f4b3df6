"""Collects the benchmark figures and prints the comparison table at the end of `make bench`."""

import pytest

RESULTS: dict[str, float] = {}


@pytest.fixture(scope="session")
def results():
    return RESULTS


def pytest_terminal_summary(terminalreporter):
    if not RESULTS:
        return
    tr = terminalreporter
    tr.section("loadarm benchmark summary")
    for key, val in RESULTS.items():
        tr.write_line(f"{key:<55s} {val:>16.6g}")
