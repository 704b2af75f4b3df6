"""The command line's help screens, log and file kinds (issue 29, items 12-16): what a new user reads."""

from __future__ import annotations

import importlib
import re

import pytest
from typer.main import get_group

from loadarm.cli import COMMAND_MODULES, GROUPS, main


def _commands():
    """(argv prefix, click command as its module defines it: help not yet made literal) of every command and
    sub-command."""
    found = []
    for name, module in COMMAND_MODULES.items():
        group = get_group(importlib.import_module(module).app)
        if name in GROUPS:
            found.append(([name], group))
            found += [([name, sub], cmd) for sub, cmd in group.commands.items()]
        else:
            found.append(([name], group.commands[name]))
    return found


COMMANDS = _commands()
IDS = [" ".join(argv) for argv, _ in COMMANDS]


def _help(capsys, monkeypatch, argv) -> str:
    monkeypatch.setenv("COLUMNS", "200")
    monkeypatch.setenv("NO_COLOR", "1")
    code = main([*argv, "--help"])
    text = capsys.readouterr().out
    assert code == 0, text
    return " ".join(text.replace("│", " ").split())


def test_every_command_and_sub_command_is_listed():
    assert {"serve", "operability", "user", "user add", "log"} <= set(IDS)


@pytest.mark.parametrize("argv, cmd", COMMANDS, ids=IDS)
def test_help_keeps_every_bracketed_word_of_the_source(capsys, monkeypatch, argv, cmd):
    """Item 12: typer renders help as rich markup, which swallowed `[guidance] and [sensor]` (serve) and
    `[operability]` (operability): every bracketed word of the docstring and the options' help is printed."""
    source = " ".join([cmd.help or "", *(getattr(p, "help", None) or "" for p in cmd.params)])
    words = re.findall(r"\[[^\[\]]+\]", source)
    text = _help(capsys, monkeypatch, argv)
    assert "\\[" not in text                               # escaped, not shown escaped
    missing = [w for w in words if " ".join(w.split()) not in text]
    assert not missing, (missing, text)


def test_the_words_the_issue_found_missing_are_there(capsys, monkeypatch):
    assert "only its [guidance] and [sensor] settings" in _help(capsys, monkeypatch, ["serve"])
    assert "[operability]" in _help(capsys, monkeypatch, ["operability"])


@pytest.mark.parametrize("argv, cmd", [([], None), *COMMANDS], ids=["loadarm", *IDS])
def test_flags_are_shown_as_flags(capsys, monkeypatch, argv, cmd):
    """Item 13: typer's rich help showed every flag as `--json <bool>`, inviting `--json true` (refused): a flag's
    row has its name and its help, no value type."""
    monkeypatch.setenv("COLUMNS", "200")
    code = main([*argv, "--help"])
    raw = capsys.readouterr().out
    assert code == 0 and "<bool>" not in raw and "--help" in raw
    flags = [] if cmd is None else [p for p in cmd.params if getattr(p, "is_flag", False)]
    for flag in flags:
        row = next(ln for ln in raw.splitlines() if re.search(rf"{re.escape(flag.opts[0])}(?![\w-])", ln))
        after = row.split(flag.opts[0], 1)[1].replace("│", " ").split()
        assert not after or not after[0].startswith("<"), row


def test_a_flag_given_a_value_is_refused_in_one_line(capsys):
    code = main(["plan", "--config", "examples/paper.toml", "--json", "true"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1


def test_log_never_cuts_a_run_id_at_80_columns(capsys, monkeypatch, tmp_path):
    """Item 14: the run column showed "drift-off@20261…" at 80 columns, yet the id is what --run takes: each run's
    id is printed whole, and it selects that run."""
    from loadarm.cli.common import out
    from loadarm.eventlog import EventLog

    db = tmp_path / "ev.db"
    ids = ["drift-off@20261107T101010.123456Z", "serve:drift-off@20261107T101011.654321Z",
           "a-scenario-with-a-long-name-" * 3 + "@20261107T101012.000000Z"]
    for run_id in ids:
        with EventLog(db, run=run_id) as log:
            log.append(1.0, "APPROACH", "operator", "start")
            log.append(2.5, "APPROACH", "mode", "STORED -> APPROACH: the operator started the approach, a reason "
                                                "long enough to wrap at eighty columns")
    monkeypatch.setenv("COLUMNS", "80")
    monkeypatch.setattr(out, "_console", None)          # a console made at 80 columns
    assert main(["log", "--db", str(db)]) == 0
    text = capsys.readouterr().out
    assert "…" not in text and all(len(ln) <= 80 for ln in text.splitlines() if ln[:1] in "┏┃┡│└")
    for run_id in ids:
        assert f"run {run_id}: 2 events" in text.splitlines()
        assert main(["log", "--db", str(db), "--run", run_id]) == 0
        one = capsys.readouterr().out
        assert f"run {run_id}: 2 events" in one and "2 events in 1 run" in one
