"""The command line's help screens, log and file kinds (issue 29, items 12-16): what a new user reads."""

from __future__ import annotations

import importlib
import json
import re

import pytest
from typer.main import get_group

from loadarm.cli import COMMAND_MODULES, GROUPS, main

from .conftest import ROOT


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


def _paragraphs(text):
    return [" ".join(p.split()) for p in re.split(r"\n\s*\n", text or "") if p.strip()]


@pytest.mark.parametrize("argv, cmd", COMMANDS, ids=IDS)
def test_help_is_reflowed_not_broken_at_the_source_s_line_ends(capsys, monkeypatch, argv, cmd):
    """Found in the second trial of issue 29: typer's rich help keeps a docstring's line ends, so `report --help`
    read "(the keys document and revision of the file's report" and "section), the date" on the next line, and the
    command lists broke "the alarm angles, the" / "sequence times" mid-row. Wide enough, each paragraph of a
    command's help is one line of its screen, and its first paragraph one row of the list it is in."""
    monkeypatch.setenv("COLUMNS", "400")
    monkeypatch.setenv("NO_COLOR", "1")
    assert main([*argv, "--help"]) == 0
    lines = capsys.readouterr().out.splitlines()
    paragraphs = [p for p in _paragraphs(cmd.help) if len(p) < 300]
    assert paragraphs
    broken = [p for p in paragraphs if not any(p in " ".join(ln.split()) for ln in lines)]
    assert not broken, broken
    assert main(argv[:-1] + ["--help"]) == 0                       # the list it is in: loadarm's, or its group's
    listing = [" ".join(ln.replace("│", " ").split()) for ln in capsys.readouterr().out.splitlines()]
    first = _paragraphs(cmd.help)[0]
    if len(first) < 300:                                           # narrower than the list's column at 400
        assert any(ln.startswith(f"{argv[-1]} {first}") for ln in listing), (first, listing)


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


EXAMPLES = ROOT / "examples"


@pytest.mark.parametrize("args, kind, command", [
    (["plan", "--config", "examples/scenarios/driftoff.toml"], "a scenario file, not an installation file",
     "loadarm run --scenario examples/scenarios/driftoff.toml"),
    (["size", "--config", "examples/berths/lng150k.toml"], "a berth file, not an installation file",
     "loadarm hydro --berth examples/berths/lng150k.toml"),
    (["plan", "--config", "examples/metocean/sample.csv"], "a metocean record, not an installation file",
     "loadarm operability --metocean examples/metocean/sample.csv"),
    (["run", "--scenario", "examples/paper.toml"], "an installation file, not a scenario file",
     "loadarm plan --config examples/paper.toml"),
    (["run", "--scenario", "examples/berths/lng150k.toml"], "a berth file, not a scenario file",
     "loadarm hydro --berth examples/berths/lng150k.toml"),
    (["hydro", "--berth", "examples/scenarios/driftoff.toml"], "a scenario file, not a berth file",
     "loadarm run --scenario examples/scenarios/driftoff.toml"),
])
def test_a_file_of_another_kind_is_named_with_the_command_that_takes_it(capsys, monkeypatch, args, kind, command):
    """Item 16: `plan --config` a scenario file said "unknown key 'scenario' ... (and 8 more problems)"."""
    monkeypatch.chdir(ROOT)
    code = main(args)
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and f"this is {kind}; `{command}` takes it" in err, err
    assert "unknown key" not in err


def test_a_file_of_the_right_kind_keeps_its_own_error(capsys, tmp_path):
    bad = tmp_path / "s.toml"
    bad.write_text("[scenario]\nduration = 100\n[drift]\nspeed = 99\n")
    assert main(["run", "--scenario", str(bad), "--no-db"]) == 2
    err = capsys.readouterr().err
    assert "drift.speed = 99" in err and "(0, 2] m/s" in err and "this is" not in err


@pytest.mark.parametrize("path, kind, command", [
    ("paper.toml", "an installation file", "loadarm plan --config"),
    ("full.toml", "an installation file", "loadarm plan --config"),
    ("datasheet.toml", "an installation file", "loadarm size --config"),
    ("scenarios/driftoff.toml", "a scenario file", "loadarm run --scenario"),
    ("scenarios/hs15_moored.toml", "a scenario file", "loadarm run --scenario"),
    ("berths/lng150k.toml", "a berth file", "loadarm hydro --berth"),
    ("metocean/sample.csv", "a metocean record", "loadarm operability --metocean"),
])
def test_validate_names_the_kind_of_every_example(capsys, path, kind, command):
    f = EXAMPLES / path
    code = main(["validate", str(f)])
    text = " ".join(capsys.readouterr().out.split())
    assert code == 0 and text.startswith(f"{f}: {kind}, valid: ") and f"`{command} {f}` takes it" in text, text
    assert main(["validate", str(f), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["valid"] is True and d["command"] == command and kind.split()[1] in (d["kind"], "installation")


@pytest.mark.parametrize("text, suffix, fragment", [
    ("[scenario]\nduration = 100\n[drift]\nspeed = 99\n", ".toml",
     "drift.speed = 99: Input should be less than or equal to 2; valid range (0, 2] m/s (read as a scenario file)"),
    ("[berth]\nwater_depth = 15\n", ".toml", "(read as a berth file)"),
    ("[datasheet]\n[arm]\n", ".toml", "missing required key 'datasheet.A'"),
    ("[datasheet]\n[moorings]\n", ".toml", "[datasheet], [moorings]: not an installation"),
    ("a = 1\n", ".toml", "[a]: not an installation ([datasheet], [arm], ...), a scenario"),
    ("# not toml\nx y\n", ".txt", "not valid TOML"),
    ("time,hs_m\n2025-01-01T00:00,1\n", ".csv", "(read as a metocean record)"),
])
def test_validate_refuses_in_one_line_exit_2(capsys, tmp_path, text, suffix, fragment):
    f = tmp_path / f"input{suffix}"
    f.write_text(text)
    code = main(["validate", str(f)])
    cap = capsys.readouterr()
    assert code == 2 and cap.out == "" and cap.err.count("\n") == 1 and cap.err.startswith(f"loadarm: error: {f}")
    assert fragment in cap.err, cap.err
    assert main(["validate", str(tmp_path / "nope.toml")]) == 2
    assert "not found" in capsys.readouterr().err


def test_every_kind_is_told_from_its_own_tables():
    from loadarm.params.kinds import KINDS, kind_of_tables

    for kind in KINDS.values():
        if kind.tables:
            assert kind_of_tables(kind.tables) is kind
    assert kind_of_tables({"ship", "environment"}) is None          # a scenario's and a berth's alike
