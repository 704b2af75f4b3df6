"""The docs cannot drift from the program.

Every ``console`` block in README.md and docs/*.md is run and its output compared, line by line, with
what the block shows. A line ``...`` in a block stands for any number of lines (a marked elision, for
wall-clock timings and the like); everything else must match exactly (trailing spaces ignored). The
commands run in a scratch directory that sees the repository's ``examples/`` and ``docs/examples/``,
so files they write never land in the repository. On a mismatch the test prints the real output, ready
to paste.
"""

from __future__ import annotations

import os
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from .conftest import ROOT

DOC_FILES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
ELISION = "..."


@dataclass
class Command:
    file: Path
    line: int
    argv: list[str]
    expected: list[str]

    @property
    def id(self) -> str:
        return f"{self.file.relative_to(ROOT)}:{self.line}"


def console_commands(path: Path) -> list[Command]:
    """Every ``$ loadarm ...`` line of every console block in ``path`` with the lines it should print."""
    cmds: list[Command] = []
    in_block = False
    for no, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if line.startswith("```"):
            in_block = line.strip() == "```console" if not in_block else False
            continue
        if not in_block:
            continue
        if line.startswith("$ "):
            cmds.append(Command(path, no, shlex.split(line[2:]), []))
        elif cmds and cmds[-1].file == path:
            cmds[-1].expected.append(line.rstrip())
        else:
            raise AssertionError(f"{path}:{no}: console block output before any '$ ' command")
    return cmds


def matches(expected: list[str], actual: list[str]) -> bool:
    """Line-by-line equality where a line ``...`` matches any run of lines, including none."""
    if not expected:
        return not actual
    if expected[0] == ELISION:
        return any(matches(expected[1:], actual[i:]) for i in range(len(actual) + 1))
    return bool(actual) and expected[0] == actual[0] and matches(expected[1:], actual[1:])


ALL = [c for f in DOC_FILES for c in console_commands(f)]


def test_docs_have_console_blocks():
    assert len(ALL) >= 6
    assert all(c.argv[0] == "loadarm" for c in ALL), [c.id for c in ALL if c.argv[0] != "loadarm"]


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    d = tmp_path_factory.mktemp("docs-run")
    (d / "examples").symlink_to(ROOT / "examples")
    (d / "docs").mkdir()
    (d / "docs" / "examples").symlink_to(ROOT / "docs" / "examples")
    return d


#: Commands that take seconds (compiling the moored ship, a mooring analysis, a Dask cluster, a scenario on the
#: hydraulic plant with its log and figure: 10 s; the forecast's twelve sea states: 8 s): checked in the slow suite
#: (CI runs it), to keep `make test` under two minutes. The scenarios themselves are checked in the fast suite by
#: tests/test_guidance.py; the forecast's checks by tests/test_forecast.py (its runs in the slow suite too).
SLOW_COMMANDS = {"alarms", "operability", "hydro", "run", "forecast"}
#: A bank's commands too (``--bank``: four arms' checks, 1.5-2.5 s each; tests/test_bank_*.py check them fast).


@pytest.mark.parametrize("cmd", [pytest.param(c, marks=pytest.mark.slow)
                                 if c.argv[1] in SLOW_COMMANDS or "--bank" in c.argv else c
                                 for c in ALL], ids=[c.id for c in ALL])
def test_console_block_matches_a_real_run(cmd, scratch):
    env = dict(os.environ, COLUMNS="80", NO_COLOR="1", TERM="dumb")
    r = subprocess.run([sys.executable, "-m", "loadarm.cli", *cmd.argv[1:]], cwd=scratch, env=env,
                       capture_output=True, text=True, timeout=120)
    actual = [ln.rstrip() for ln in (r.stdout + r.stderr).splitlines()]
    assert matches(cmd.expected, actual), (
        f"{cmd.id}: `{shlex.join(cmd.argv)}` printed (exit {r.returncode}):\n" + "\n".join(actual))


@pytest.mark.parametrize("expected, actual, ok", [
    (["a", "b"], ["a", "b"], True),
    (["a", "b"], ["a", "c"], False),
    (["a", "..."], ["a", "x", "y"], True),
    (["a", "..."], ["a"], True),
    (["...", "b"], ["x", "b"], True),
    (["a", "...", "b"], ["a", "b"], True),
    (["a", "...", "b"], ["a", "x", "y", "b"], True),
    (["a", "...", "b"], ["a", "x", "y"], False),
    (["a"], ["a", "extra"], False),
    (["a.b"], ["axb"], False),
])
def test_elision_matcher(expected, actual, ok):
    assert matches(expected, actual) is ok


def test_every_figure_in_the_docs_is_generated():
    """Every image the docs show is in docs/img and drawn by `make docs`; nothing else sits in docs/img."""
    import re as _re

    from loadarm.present.docsgen import DOC_FIGURES, HMI_SCREENSHOTS, REPORT_PAGES, STUDY_FIGURES

    # the screen's and the report's page (a real browser) and the studies' too
    DOC_FIGURES = DOC_FIGURES + HMI_SCREENSHOTS + REPORT_PAGES + STUDY_FIGURES
    shown = set()
    for f in DOC_FILES:
        shown |= {Path(m).name for m in _re.findall(r"\]\(((?:docs/)?img/[^)]+\.png)\)", f.read_text())}
    on_disk = {p.name for p in (ROOT / "docs" / "img").glob("*.png")}
    assert shown == set(DOC_FIGURES) == on_disk, (shown ^ set(DOC_FIGURES), on_disk ^ set(DOC_FIGURES))


@pytest.mark.slow
def test_committed_figures_match_what_the_code_draws(tmp_path):
    """Redraw every docs figure from the paper's case and compare with the committed PNG (`make docs`)."""
    from loadarm.present.docsgen import compare_figures, render_doc_figures

    bad = compare_figures(ROOT / "docs" / "img", render_doc_figures(tmp_path))
    assert not bad, "stale figures (run `make docs`): " + "; ".join(bad)
