"""``loadarm report``: an installation's report, its HTML and, with ``--pdf``, the PDF to sign."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from loadarm.cli.common import ConfigOpt, ForceOpt, out, progress_bar
from loadarm.files import guard_outputs
from loadarm.params.config import Installation, load_config
from loadarm.present.pdf import chromium_or_fail
from loadarm.present.report import build_report, report_outputs

__all__ = ["app", "report_steps"]

app = typer.Typer()


def report_steps(inst: Installation, pdf: bool) -> int:
    """Steps of :func:`loadarm.present.report.build_report`'s progress, for the bar.

    Parameters
    ----------
    inst : Installation
    pdf : bool

    Returns
    -------
    int
    """
    return 13 + len(inst.report.scenarios) + (inst.report.metocean is not None) + (inst.report.bank is not None) + pdf


@app.command()
def report(
    config: ConfigOpt,
    out_dir: Annotated[Path, typer.Option("--out", help="Output directory for report.html (and report.pdf), "
                                                        "summary.json, CSV and figures.")] = Path("report"),
    pdf: Annotated[bool, typer.Option("--pdf", help="Print report.pdf with Chromium too (a document to sign: "
                                                    "page numbers, table of contents, approval block).")] = False,
    force: ForceOpt = False,
) -> None:
    """Write the report of an installation: report.html, summary.json, CSV and figures; with --pdf, report.pdf.

    The title page carries the document number and revision (the keys document and revision of the file's report
    section), the date, the input file's SHA-256, an approval block and the table of contents.

    Example: loadarm report --config examples/paper.toml --out out --pdf
    """
    inst = load_config(config)
    if pdf:
        chromium_or_fail()                                               # one line, exit 2, before any work
    outputs, scenario_files = report_outputs(inst, out_dir, config, pdf=pdf)
    guard_outputs([("--out", p) for p in outputs], [config, *scenario_files], force=force)
    steps = report_steps(inst, pdf)
    with progress_bar() as prog:
        task = prog.add_task("starting", total=steps)

        def step(msg: str) -> None:
            prog.update(task, description=msg, advance=1)

        files = build_report(inst, out_dir, title=f"loadarm report: {config.name}", source=config, progress=step,
                             force=force, pdf=pdf)
        prog.update(task, description="done", completed=steps)
    out.print(f"report: {files.html}")
    if files.pdf is not None:
        out.print(f"pdf: {files.pdf}")
    out.print(f"summary: {files.summary}")
