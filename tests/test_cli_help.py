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
