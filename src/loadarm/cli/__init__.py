"""Command line: ``loadarm size | plan | envelope | check | verify | balance | loads | simulate | run | campaign | log |
mjcf | demo | report | hydro | alarms | operability | forecast | serve | plc-sim | trust | user | validate |
warmup``.

Bad input of any kind (missing file, invalid config, unreachable target,
malformed option) prints one line on stderr and exits with status 2; there is
never a Python traceback for a user error. Exit codes: 0 ok, 1 internal error
(a bug: one line, the traceback with ``LOADARM_DEBUG=1``), 2 bad input,
130 interrupted.

One module per command family (``cli.plan``, ``cli.run``, ...), each importing what its commands need at its top.
:data:`COMMAND_MODULES` names the module of every command: a command's module is imported when the command runs, so
``loadarm plan`` never loads the simulator, MuJoCo or matplotlib (``tests/test_architecture.py``).
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from typing import Annotated

import typer
from typer.core import TyperGroup
from typer.main import get_group

from loadarm import __version__
from loadarm.cli.common import EXIT_CODES, UserError, err, fail, out
from loadarm.errors import LoadarmError

__all__ = ["COMMAND_MODULES", "app", "main"]

#: Every command, in the order ``loadarm --help`` lists them, and the module that defines it (on a Typer ``app``
#: of its own). ``user`` is a group (``loadarm user add``).
COMMAND_MODULES = {
    "size": "loadarm.cli.sizing", "plan": "loadarm.cli.plan", "envelope": "loadarm.cli.plan",
    "verify": "loadarm.cli.verify", "balance": "loadarm.cli.dynamics", "loads": "loadarm.cli.dynamics",
    "simulate": "loadarm.cli.dynamics", "run": "loadarm.cli.run", "check": "loadarm.cli.check",
    "hydro": "loadarm.cli.ship", "alarms": "loadarm.cli.ship", "operability": "loadarm.cli.studies",
    "forecast": "loadarm.cli.forecast",
    "campaign": "loadarm.cli.studies", "log": "loadarm.cli.run", "mjcf": "loadarm.cli.verify",
    "demo": "loadarm.cli.demo", "report": "loadarm.cli.report", "serve": "loadarm.cli.plant", "plc-sim": "loadarm.cli.plant",
    "trust": "loadarm.cli.plant", "user": "loadarm.cli.users", "validate": "loadarm.cli.validate",
    "warmup": "loadarm.cli.warmup",
}
#: The real-time servers: stopped by Ctrl-C, they have closed all they hold (the event log flushed and closed, the
#: servers stopped, the closing line printed) and the process ends at once, without the interpreter's teardown of
#: their threads and compiled kernels (found, issue 29: about a second after the last line).
QUICK_EXIT = frozenset({"serve", "plc-sim"})
#: Commands that are groups of their own (their module's whole ``app``).
GROUPS = frozenset({"user"})


#: What rich's help renderer would take for a markup tag (``[guidance]``, ``[/x]``, ``[#fff]``; rich.markup's
#: grammar): the help screens escape it, so a docstring's TOML section names are printed, not swallowed.
_MARKUP_TAG = re.compile(r"(\\*)(\[[a-z#/@][^[]*?])")


def _literal(text: str | None) -> str | None:
    """``text`` with every would-be rich markup tag escaped (rich.markup.escape's rule, without importing rich:
    ``loadarm plan --json`` never loads it)."""
    return None if text is None else _MARKUP_TAG.sub(lambda m: f"{m[1]}{m[1]}\\{m[2]}", text)


def _reflowed(text: str | None) -> str | None:
    """``text`` with each paragraph on one line: typer's rich help keeps a docstring's line ends, so a help screen
    broke its sentences where the source did ("the file's report" / "section)"), not at the window's edge."""
    if text is None:
        return None
    return "\n\n".join(" ".join(p.split()) for p in re.split(r"\n\s*\n", text.strip()))


def literal_help(cmd, ctx) -> None:
    """Make a command's help screen say what its source says (issue 29, items 12-13), and its sub-commands':

    * help texts are literal: typer renders them as rich markup, which swallowed ``[guidance] and [sensor]`` in
      ``serve --help`` and ``[operability]`` in ``operability --help``; every text is escaped;
    * each paragraph is one line, wrapped by the screen's width (typer kept the docstring's line ends);
    * a flag is shown as a flag: typer's rich help gave every bool option a ``<bool>`` type, inviting
      ``--json true`` (which fails); a flag's value column is left empty.
    """
    if getattr(cmd, "_loadarm_literal", False):
        return
    cmd._loadarm_literal = True
    cmd.help, cmd.short_help, cmd.epilog = (_reflowed(_literal(text))
                                            for text in (cmd.help, cmd.short_help, cmd.epilog))
    for param in [*cmd.params, cmd.get_help_option(ctx)]:
        if param is None:
            continue
        param.help = _literal(getattr(param, "help", None))
        if getattr(param, "is_flag", False) and not getattr(param, "count", False):
            param.metavar = ""                  # typer's rich help prints the metavar as the type: none
    for sub in getattr(cmd, "commands", {}).values():
        literal_help(sub, ctx)


class _Commands(TyperGroup):
    """The top-level group: it knows its commands' names from :data:`COMMAND_MODULES` and imports a command's module
    only when that command is asked for (to run it, or to list its help). Every command's help is made literal
    (:func:`literal_help`)."""

    def list_commands(self, ctx) -> list[str]:
        return list(COMMAND_MODULES)

    def get_command(self, ctx, cmd_name: str):
        if cmd_name not in COMMAND_MODULES:
            return None
        group = get_group(importlib.import_module(COMMAND_MODULES[cmd_name]).app)
        cmd = group if cmd_name in GROUPS else group.commands.get(cmd_name)
        if cmd is not None:
            literal_help(cmd, ctx)
        return cmd

    def format_help(self, ctx, formatter) -> None:
        literal_help(self, ctx)
        super().format_help(ctx, formatter)


app = typer.Typer(cls=_Commands, add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Automatic guidance of marine loading arms: sizing, envelope, straight-line approach, "
                       "hydraulics, live guidance, event log, report.",
                  epilog=EXIT_CODES)


def _version(value: bool) -> None:
    if value:
        out.print(f"loadarm {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                          help="Print the version and exit.")] = False,
) -> None:
    """Automatic guidance of marine loading arms: sizing, envelope, straight-line approach, hydraulics, live
    guidance, event log, report."""


def _explained(exc: Exception) -> str:
    """An error's line; a file refused by the reader of one kind of input that is another kind is named for what
    it is, with the command that takes it (:func:`loadarm.params.kinds.wrong_kind`, loaded only then)."""
    expected = getattr(exc, "expected", None)
    if expected is None:
        return str(exc)
    return importlib.import_module("loadarm.params.kinds").wrong_kind(exc.source, expected) or str(exc)


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns (and exits with) the process status.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 ok, 1 internal error, 2 bad input, 3 a run whose verdict is FAILED (``loadarm run``), 130 interrupted.
    """
    args = sys.argv[1:] if argv is None else argv
    try:
        rv = app(args=args, prog_name="loadarm", standalone_mode=False)
        code = rv if isinstance(rv, int) else 0
    except (LoadarmError, UserError, ValueError) as exc:
        fail(_explained(exc))
        code = 2
    except OSError as exc:
        fail(f"{exc.strerror or exc}: {exc.filename or ''}".rstrip(": "))
        code = 2
    except Exception as exc:
        # click-style exceptions (typer vendors click in recent releases, so match by shape, not by class)
        name = type(exc).__name__
        if name == "Exit" and hasattr(exc, "exit_code"):
            code = int(exc.exit_code)
        elif name == "NoArgsIsHelpError":  # the help text has already been printed
            code = 2
        elif hasattr(exc, "format_message") and hasattr(exc, "exit_code"):
            fail(exc.format_message())
            code = 2
        elif name == "Abort":
            fail("aborted")
            code = 130
        elif os.environ.get("LOADARM_DEBUG"):
            raise
        else:
            err.print(f"loadarm: internal error: {type(exc).__name__}: {' '.join(str(exc).split())} (this is a "
                      "bug; LOADARM_DEBUG=1 shows the traceback)")
            code = 1
    except KeyboardInterrupt:
        fail("interrupted")
        code = 130
    if argv is None and code == 130 and args[:1] and args[0] in QUICK_EXIT:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    if argv is None:
        sys.exit(code)
    return code


if __name__ == "__main__":  # pragma: no cover
    main()
