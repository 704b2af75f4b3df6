"""The report as a document to sign: Chromium's print to PDF of ``report.html`` (``loadarm report --pdf``,
``loadarm demo``).

Chromium is driven on its command line (headless, none of its own network traffic, a throw-away profile), so
no Python browser driver is needed at run time: :func:`print_pdf`. The page size, margins and page numbers are the
report's print stylesheet (``@page``: A4, "page n of N" in the bottom margin); Chromium's own header and footer
(the file's URL and the print date) are off. Headings become the PDF's outline (bookmarks): :func:`pdf_outline`
reads them back, which is how the tests find every section in the PDF without a PDF library.
"""

from __future__ import annotations

import re
import subprocess
import tempfile
from pathlib import Path

from loadarm.errors import LoadarmError
from loadarm.files import atomic_path
from loadarm.testing.browser import CHROMIUM_HINT, find_chromium

__all__ = ["PdfError", "CHROMIUM_FLAGS", "print_pdf", "pdf_outline", "chromium_or_fail"]

#: Chromium's flags for printing: headless, no sandbox (as root in a container), and none of its background
#: connections (on a closed network they fail, many at a time).
CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--no-first-run",
                  "--disable-component-update", "--disable-sync")

#: Longest a print may take, s (the demo's report, 28 pages with 30 figures: 2 s).
PRINT_TIMEOUT = 180.0


class PdfError(LoadarmError):
    """No Chromium to print with, or Chromium did not write the PDF (exit 2, one line)."""


def chromium_or_fail() -> str:
    """The Chromium to print with, or :class:`PdfError` with the install hint.

    Returns
    -------
    str
        Its path (:func:`loadarm.testing.browser.find_chromium`).

    Raises
    ------
    PdfError
        None found.
    """
    exe = find_chromium()
    if exe is None:
        raise PdfError(f"--pdf needs Chromium: {CHROMIUM_HINT}")
    return exe


def print_pdf(html: str | Path, pdf: str | Path, *, chromium: str | None = None) -> Path:
    """Print an HTML file to PDF with Chromium, atomically.

    Parameters
    ----------
    html : str or Path
        The report (self-contained: its figures embedded).
    pdf : str or Path
        The PDF to write.
    chromium : str, optional
        The browser (default :func:`chromium_or_fail`).

    Returns
    -------
    Path
        ``pdf``.

    Raises
    ------
    PdfError
        No Chromium, or it failed or timed out (its last line of output in the message).
    """
    exe = chromium or chromium_or_fail()
    pdf = Path(pdf)
    with tempfile.TemporaryDirectory(prefix="loadarm-chromium-") as profile, atomic_path(pdf) as tmp:
        cmd = [exe, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", f"--print-to-pdf={tmp}", "--no-pdf-header-footer",
               "--generate-pdf-document-outline", Path(html).resolve().as_uri()]
        try:
            run = subprocess.run(cmd, stdin=subprocess.DEVNULL, capture_output=True, timeout=PRINT_TIMEOUT,
                                 check=False)
        except subprocess.TimeoutExpired:
            raise PdfError(f"Chromium did not print {pdf.name} within {PRINT_TIMEOUT:g} s") from None
        except OSError as exc:
            raise PdfError(f"Chromium ({exe}) could not start: {exc.strerror or exc}") from None
        if not tmp.exists() or tmp.read_bytes()[:5] != b"%PDF-":
            lines = [ln for ln in run.stderr.decode(errors="replace").splitlines() if ln.strip()]
            raise PdfError(f"Chromium did not print {pdf.name} (exit {run.returncode}"
                           + (f": {lines[-1].strip()}" if lines else "") + ")")
    return pdf


_TITLE = re.compile(rb"/Title\s*\(((?:[^()\\]|\\.)*)\)")


def pdf_outline(pdf: str | Path) -> list[str]:
    """The titles of a Chromium PDF's outline (its headings, in order), the document's own title first.

    Chromium writes them as literal strings outside any compressed stream; a title outside ASCII is written in
    hexadecimal and left out here.

    Parameters
    ----------
    pdf : str or Path

    Returns
    -------
    list of str
    """
    data = Path(pdf).read_bytes()
    out = []
    for m in _TITLE.finditer(data):
        text = re.sub(rb"\\(.)", rb"\1", m.group(1))
        out.append(text.decode("latin-1"))
    return out
