"""When the true flange first crosses a face after the connection (the run's overstretch look-ahead), and the watch
that the released coupler clears the ship's manifold in time.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.faces import FACES, face_margins, first_face
from loadarm.design.check import MANIFOLD_CLEARANCE
from loadarm.vocab import event_label

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["LIMIT_LOOKAHEAD", "CLEARANCE_TIME", "first_limit", "ClearanceWatch"]


#: The time the coupler has to put :data:`loadarm.design.check.MANIFOLD_CLEARANCE` between itself and the ship's flange
#: after a release, s.
CLEARANCE_TIME = 30.0


#: How far past the end of a run the flange's own trajectory is followed to find the face it would reach, s.
LIMIT_LOOKAHEAD = 600.0


def first_limit(model: ArmModel, sig: dict, flange: np.ndarray, motion) -> tuple[float | None, str]:
    """First time after the first connection the true flange is past a face of the envelope: in the run, or on
    the flange's own trajectory up to :data:`LIMIT_LOOKAHEAD` s after it (a slow drift whose alarm came before
    the run ended still reaches its face).

    Parameters
    ----------
    model : ArmModel
        The installation.
    sig : dict
        The run's signals (``t``, ``connected``).
    flange : ndarray, shape (n, 3)
        The true flange at each sample, m.
    motion : FlangeMotion
        The flange's trajectory, for the look-ahead.

    Returns
    -------
    t : float or None
        s (None: no face crossed).
    face : str
        The face (:data:`loadarm.vocab.FACES`), ``""`` for none.
    """
    conn = np.flatnonzero(sig["connected"] > 0)
    if conn.size == 0:
        return None, ""
    k0 = int(conn[0])
    t_end = float(sig["t"][-1])
    after = t_end + np.arange(1, int(LIMIT_LOOKAHEAD / 0.1) + 1) * 0.1
    tt = np.concatenate([sig["t"][k0:], after])
    p = np.concatenate([flange[k0:], motion.position(after)])
    outside, face = first_face(face_margins(model, p[:, 0], p[:, 1], p[:, 2]))
    hit = np.flatnonzero(outside)
    if hit.size == 0:
        return None, ""
    return float(tt[hit[0]]), FACES[int(face[hit[0]])]


class ClearanceWatch:
    """After a release the coupler must be :data:`MANIFOLD_CLEARANCE` from the flange within
    :data:`CLEARANCE_TIME`; otherwise an alarm (the arm may strike the ship's manifold). A distance of NaN is
    unknown (no flange position): unknown at the deadline raises the alarm too, saying so (the operator must see
    the coupler clear)."""

    def __init__(self, emit: Callable):
        self.emit = emit
        self.released_at: float | None = None
        self.done = False
        self.was_connected = False

    def watch(self, now: float, cmd, distance: float) -> None:
        if self.was_connected and not cmd.connected:      # released or unclamped this cycle
            self.released_at, self.done = now, False
        self.was_connected = cmd.connected
        if self.released_at is None or self.done:
            return
        if distance >= MANIFOLD_CLEARANCE:
            self.done = True
        elif now - self.released_at > CLEARANCE_TIME:
            self.done = True
            where = ("flange position unknown" if math.isnan(distance)
                     else f"{distance:.2f} m from the flange")
            self.emit(now, cmd.mode.value, "alarm", f"{event_label('fault.not_clear')}: {CLEARANCE_TIME:g} s after "
                      f"the release ({where}, {MANIFOLD_CLEARANCE:g} m needed)", {"code": "fault.not_clear"})
