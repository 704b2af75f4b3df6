"""Exceptions raised by loadarm.

Every error a user can provoke with bad input derives from :class:`LoadarmError`;
the ones caused by an out-of-range value also derive from :class:`ValueError`.
Messages are one line and name the offending value and the valid range, so the
command line can print them verbatim (exit status 2) without a traceback.
"""

from __future__ import annotations

__all__ = ["LoadarmError", "ConfigError", "OutputError", "EventLogError", "UnreachableError", "PathError",
           "TimingError", "SizingError", "ActuatorError", "ValveRangeError", "ReleaseError"]


class LoadarmError(Exception):
    """Base class of every error loadarm raises on purpose."""


class ConfigError(LoadarmError, ValueError):
    """A configuration file is missing, malformed, or holds an invalid value.

    Attributes
    ----------
    source : str or None
        The file refused, when a reader of one kind of input refused it (an installation, a scenario, a berth).
    expected : str or None
        That kind (``"installation"``, ``"scenario"``, ``"berth"``): the command line then names the kind the file
        really is and the command that takes it (:mod:`loadarm.params.kinds`; issue 29, item 16).
    """

    def __init__(self, message: str = "", *, source: str | None = None, expected: str | None = None):
        super().__init__(message)
        self.source, self.expected = source, expected


class OutputError(LoadarmError):
    """An output file would destroy something: an input of the same command, a file loadarm did not write
    (without ``--force``), or a directory or special file."""


class EventLogError(LoadarmError, ValueError):
    """An event-log database is not loadarm's, is corrupt, is of a newer schema, or cannot be written; or an
    event is malformed."""


class UnreachableError(LoadarmError, ValueError):
    """A coupler position lies outside the annulus the arm can reach.

    Attributes
    ----------
    point : tuple of float
        The first offending coupler position ``(x, y)`` in metres.
    r : float
        Its distance from the riser top in metres.
    r_min, r_max : float
        Reachable radii ``|b - c|`` and ``b + c`` in metres.
    """

    def __init__(self, message: str, *, point: tuple[float, float], r: float, r_min: float, r_max: float):
        super().__init__(message)
        self.point = point
        self.r = r
        self.r_min = r_min
        self.r_max = r_max


class PathError(LoadarmError, ValueError):
    """A straight-line path cannot be executed (degenerate, or leaves the workspace)."""


class TimingError(LoadarmError, ValueError):
    """A timing law cannot be applied to the requested path or limits."""


class SizingError(LoadarmError, ValueError):
    """The arm-sizing problem (paper Eq. 3) has no solution inside the bounds."""


class ActuatorError(LoadarmError, ValueError):
    """Cylinder lengths or joint angles outside what the mounting geometry allows."""


class ValveRangeError(LoadarmError, ValueError):
    """A plan would need a valve voltage beyond the configured valve range."""


class ReleaseError(LoadarmError, ValueError):
    """A bank's power unit cannot release every arm at once with its pumps lost (issue 31, item 5): its
    accumulators run out, or a step of the sequence ends late.

    Attributes
    ----------
    result : object
        The release as simulated (``loadarm.hydraulics.bank_release.BankRelease``).
    """

    def __init__(self, message: str, *, result=None):
        super().__init__(message)
        self.result = result
