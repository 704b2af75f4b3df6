"""``loadarm demo``: the paper's case end to end, the report in one folder."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from loadarm.cli.common import ForceOpt, out, progress_bar
from loadarm.cli.report import report_steps
from loadarm.files import guard_outputs
from loadarm.params.config import Installation, load_config, packaged_example
from loadarm.present.report import build_report, report_outputs
from loadarm.testing.browser import CHROMIUM_HINT, find_chromium

__all__ = ["app"]

app = typer.Typer()


@app.command()
def demo(
    out_dir: Annotated[Path, typer.Option("--out", help="Output directory for report.html, CSV and figures.")] = Path("out"),
    config: Annotated[Optional[Path], typer.Option("--config", "-c", help="Installation TOML (default: the paper's case).")] = None,
    force: ForceOpt = False,
) -> None:
    """Run an installation end to end (default: the paper's case) and write a self-contained HTML report, and its
    PDF when Chromium is installed.

    Example: loadarm demo --config examples/paper.toml --out out
    """

    source = config if config is not None else packaged_example("paper.toml")
    inst: Installation = load_config(source)
    pdf = find_chromium() is not None                 # the PDF when Chromium is here; said in one line when not

    outputs, scenario_files = report_outputs(inst, out_dir, source, pdf=pdf)   # refused before any work or bar
    guard_outputs([("--out", p) for p in outputs], [source, *scenario_files], force=force)
    steps = report_steps(inst, pdf)
    with progress_bar() as prog:
        task = prog.add_task("starting", total=steps)

        def step(msg: str) -> None:
            prog.update(task, description=msg, advance=1)

        files = build_report(inst, out_dir, title="loadarm: the paper's case end to end" if config is None
                             else f"loadarm report: {config.name}", source=source, progress=step, force=force,
                             pdf=pdf)
        prog.update(task, description="done", completed=steps)
    out.print(f"report: {files.html}")
    out.print(f"pdf: {files.pdf}" if files.pdf is not None else f"pdf: skipped ({CHROMIUM_HINT})")
    out.print(f"summary: {files.summary}")
    for name, p in files.csv.items():
        out.print(f"samples ({name} timing): {p}")
