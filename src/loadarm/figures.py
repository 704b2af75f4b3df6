"""The figure canvas every plot module draws on, and the one way a figure is saved.

Every figure function of loadarm (one plot module per domain: ``design.plots``, ``hydraulics.plots``,
``sim.plots``, ``studies.plots``) returns a :class:`matplotlib.figure.Figure` and never shows it. Figures are made
without pyplot (:func:`subplots`): no backend is chosen at import, so a notebook user's stays theirs, and a machine
with no screen needs none (a figure saves through Agg). matplotlib itself is imported when the first figure is
drawn, so a command that draws nothing never loads it.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from loadarm import __version__
from loadarm.files import SIGNATURE, atomic_open

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["subplots", "save"]


def subplots(*args, figsize=None, **kw):
    """A new figure and its axes, without pyplot (no backend chosen, no global figure kept).

    Parameters
    ----------
    *args, **kw
        As :meth:`matplotlib.figure.Figure.subplots` (rows, columns, ``sharex``, ``gridspec_kw``, ...).
    figsize : tuple of float, optional
        Inches.

    Returns
    -------
    fig : Figure
    axes : Axes or ndarray of Axes
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.subplots(*args, **kw)


def save(fig: Figure, path: str | Path, dpi: int = 110) -> Path:
    """Save a figure as PNG and close it.

    Parameters
    ----------
    fig : Figure
        The figure.
    path : str or Path
        Output file; parent directories are created; written atomically (:func:`loadarm.files.atomic_open`)
        with loadarm's mark in the PNG's ``Software`` text.
    dpi : int
        Resolution.

    Returns
    -------
    Path
        The file written.
    """
    p = Path(path)
    try:
        with atomic_open(p, "wb") as fh:          # a reader never sees half a PNG; the mark tells it is loadarm's
            fig.savefig(fh, dpi=dpi, format="png", metadata={"Software": f"{SIGNATURE} {__version__}"})
    finally:
        fig.clear()                               # no pyplot: nothing else holds the figure
    return p
