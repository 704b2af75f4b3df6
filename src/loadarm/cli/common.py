"""What every command shares: the consoles (rich, imported on first use), the common options, the checks of\noutputs
and points, the JSON printer.
"""

from __future__ import annotations

import json
import math
import sys
from enum import Enum
from pathlib import Path
from typing import Annotated, Optional

import typer

from loadarm.eventlog import KINDS
from loadarm.files import guard_outputs, printable
from loadarm.params.compiler import compile_model
from loadarm.params.config import load_config
from loadarm.results import round_floats

EXIT_CODES = "Exit codes: 0 ok, 1 internal error (a bug; LOADARM_DEBUG=1 shows the traceback), 2 bad input, 130 interrupted."


#: Exit status of `loadarm run` when the run's verdict is FAILED (0 success, 1 internal error, 2 bad input).
SAFETY_FAILED = 3


class _LazyConsole:
    """A rich Console created on first use: `plan --json` and other machine-facing paths never import rich."""

    def __init__(self, **kwargs):
        self._kwargs = kwargs
        self._console = None

    def get(self):
        """The real Console (for rich objects that take one, such as a progress bar)."""
        if self._console is None:
            from rich.console import Console

            self._console = Console(**self._kwargs)
        return self._console

    def __getattr__(self, name):
        return getattr(self.get(), name)

    def print(self, *objects, **kwargs) -> None:
        """Console.print with every string made :func:`loadarm.files.printable` (user text never reaches the
        terminal raw)."""
        self.get().print(*(printable(o) if isinstance(o, str) else o for o in objects), **kwargs)


def escape(text: str) -> str:
    """Escape rich markup in user text (rich imported on first use)."""
    from rich.markup import escape as _escape

    return _escape(text)


def Table(*args, **kwargs):  # noqa: N802 - stands in for rich.table.Table
    """A rich Table (rich imported on first use) whose title and cells are made :func:`loadarm.files.printable`."""
    from rich.table import Table as _Table

    class _Printable(_Table):
        def add_row(self, *cells, **kw):
            super().add_row(*(printable(c) if isinstance(c, str) else c for c in cells), **kw)

    if isinstance(kwargs.get("title"), str):
        kwargs["title"] = printable(kwargs["title"])
    return _Printable(*args, **kwargs)


# Markup off: user strings (scenario names, paths, log reasons) are printed as they are, never parsed ("[/x]" in a
# path once raised rich's MarkupError, "[link=...]" changed what was printed). The few styled lines opt in with
# markup=True and escape what they interpolate.
out = _LazyConsole(soft_wrap=True, markup=False, highlight=False)


err = _LazyConsole(stderr=True, soft_wrap=True, markup=False, highlight=False)


ConfigOpt = Annotated[Path, typer.Option("--config", "-c", help="Installation TOML file (see examples/paper.toml).")]


JsonOpt = Annotated[bool, typer.Option("--json", help="Print machine-readable JSON on stdout.")]


ForceOpt = Annotated[bool, typer.Option("--force", help="Replace existing output files that loadarm did not write "
                                                        "(its own are replaced without it).")]


class UserError(Exception):
    """A CLI-level bad input (exit status 2)."""


class Timing(str, Enum):
    """Timing laws of the approach."""

    paper = "paper"
    smooth = "smooth"
    optimal = "optimal"


class TimingOrAll(str, Enum):
    """Timing laws, or all three compared."""

    paper = "paper"
    smooth = "smooth"
    optimal = "optimal"
    all = "all"


class PlantKind(str, Enum):
    """Arm plants of a guidance run."""

    hydraulic = "hydraulic"
    kinematic = "kinematic"


EventKind = Enum("EventKind", {k: k for k in KINDS}, type=str)


POINT_HELP = ("X,Y: x out from the riser centre line and height above the jetty deck (arm plane); X,Y,Z: x out, "
              "y along the berth, z height (3D with slew); metres")


def parse_point(text: Optional[str], name: str) -> Optional[tuple[float, ...]]:
    if text is None:
        return None
    parts = text.split(",")
    try:
        if len(parts) not in (2, 3):
            raise ValueError
        vals = tuple(float(p) for p in parts)
    except ValueError:
        raise UserError(f"{name} must be X,Y (arm plane) or X,Y,Z (3D) in metres, separated by commas, "
                        f"got {text!r}") from None
    if not all(math.isfinite(v) and abs(v) <= POINT_LIMIT for v in vals):     # found: 1e308 overflowed numpy
        raise UserError(f"{name} must be numbers in [-{POINT_LIMIT:g}, {POINT_LIMIT:g}] m, got {text!r}")
    return vals


#: The largest coordinate a point on the command line may have, m (a loading arm reaches tens of metres).
POINT_LIMIT = 1000.0


def check_png(png: Optional[Path]) -> None:
    if png is not None and png.suffix.lower() != ".png":
        raise UserError(f"--png must name a .png file, got {str(png)!r}")


def check_outputs(outputs: dict, inputs=(), force: bool = False, appended=()) -> None:
    """Check the output files before any work (:func:`loadarm.files.guard_outputs`), and a PNG's suffix."""

    check_png(outputs.get("--png"))
    guard_outputs(outputs, [Path(i) for i in inputs if i is not None], force=force, appended=appended)


def check_fill(fill: Optional[float]) -> None:
    if fill is not None and not (0.0 <= fill <= 1.0):
        raise UserError(f"--fill must be in [0, 1], got {fill!r}")


def print_wide(renderable, width: int) -> None:
    """Print on stdout at least ``width`` columns wide (rich squeezes a table into 80 columns when piped)."""
    from rich.console import Console

    Console(width=max(out.width, width), soft_wrap=True, markup=False, highlight=False,
            file=out.file).print(renderable)


def read_model(config: Path):
    """Read an installation file and compile it (the CLI is an edge: configuration stops here)."""

    return compile_model(load_config(config), source=str(config))


def progress_bar():
    """A progress bar on stderr (rich.progress is imported only by the commands that show one). Transient: it
    leaves nothing behind, so a refusal mid-way is still the one line on stderr (found by the fuzz suite: a
    bad scenario in a campaign printed the bar's last state above the error)."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    class _Printable(Progress):
        def add_task(self, description, *args, **kwargs):
            return super().add_task(printable(str(description)), *args, **kwargs)

    return _Printable(TextColumn("{task.description}", style="bold", markup=False), BarColumn(), TimeElapsedColumn(),
                      console=err.get(), transient=True)


class lazy_progress:  # noqa: N801 - used like progress_bar
    """A progress bar that appears at the first progress report: the checks before the work refuse in one line
    with no bar drawn (found: the operability bar left an empty line above a refused record's error).

    Parameters
    ----------
    description : str
    """

    def __init__(self, description: str):
        self.description, self._bar, self._task = description, None, None

    def __call__(self, done: int, total: int) -> None:
        if self._bar is None:
            self._bar = progress_bar()
            self._bar.start()
            self._task = self._bar.add_task(self.description, total=total)
        self._bar.update(self._task, completed=done, total=total)

    def __enter__(self) -> "lazy_progress":
        return self

    def __exit__(self, *exc) -> None:
        if self._bar is not None:
            self._bar.stop()


def print_json(obj) -> None:
    try:
        text = json.dumps(round_floats(obj), indent=2, allow_nan=False)
    except ValueError as exc:                 # a NaN or infinity in a result is a bug, not bad input: exit 1
        raise RuntimeError(f"a result is not a finite number ({exc})") from None
    sys.stdout.write(text + "\n")


def fail(message: str) -> None:
    err.print(f"loadarm: error: {' '.join(message.split())}")


BerthOpt = Annotated[Path, typer.Option("--berth", "-b", help="Berth TOML file (see examples/berths/).")]


def latest_run(events, empty: str) -> tuple[str, list]:
    """The log's latest run with state samples and its events (several runs in one log: the latest is
    replayed, or one chosen with --run); ``empty`` is the error when there is none."""
    samples = [e for e in events if e.kind == "sample"]
    if not samples:
        raise UserError(empty)
    run = samples[-1].run
    return run, [e for e in events if e.run == run]
