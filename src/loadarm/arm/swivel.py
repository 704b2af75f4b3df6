"""The flange's full pose and the style-80 triple swivel (issue 31, item 2).

The coupler has an orientation as well as a position. Between the outboard arm's tip and the coupler, the
style-80 triple swivel gives it three more rotations, so that the coupler, bolted or clamped to the ship's
presentation flange, follows the ship's roll, pitch and yaw while the arm's three joints (slew, inboard,
outboard) follow the flange's position.

Frames (right-handed, SI, angles in rad), the arm's frame of :mod:`loadarm.arm.slew`: ``x`` horizontal towards
the ship, ``y`` along the berth, ``z`` up.

* The **outboard arm's tip frame** is ``Rz(phi) Ry(gamma)`` with ``gamma = alpha - beta`` the outboard arm's angle
  from hanging straight down (at ``gamma = 0`` the outboard arm hangs plumb from the elbow; positive ``gamma``
  swings its lower end towards the jetty, :func:`loadarm.arm.kinematics.forward`). ``Ry`` turns about the arm's
  hinge axis (the slewed ``y``).
* The **coupler frame**: its ``x`` axis is the flange's normal, out of the coupler towards the ship, its ``z``
  axis up when the ship is at rest; at rest, with the outboard arm plumb and no slew, it is the arm's frame.
* The **triple swivel**, from the tip to the coupler: swivel 1 about the hinge axis (it lets the coupler hang
  plumb whatever the outboard arm's angle, and takes the ship's rotation about that axis: the roll of a ship
  lying along the berth), swivel 2 about the coupler's vertical drop (the ship's yaw and the slew), swivel 3 about
  the flange's normal (the pitch of a ship alongside; found: this said pitch and roll the other way round, true
  only of a ship lying across the berth; ``tests/test_bank.py`` holds the alongside case). So the coupler's orientation is ``Rz(phi) Ry(gamma) Ry(s1) Rz(s2) Rx(s3)``: an intrinsic y-z-x
  (Tait-Bryan) chain whose one singularity, ``s2 = +-90 deg`` (the flange's normal along the hinge axis), lies
  far outside any swivel's travel.

The ship's rotation at the manifold (roll about its own longitudinal axis, pitch about its transverse axis, yaw
about its vertical) is given in the ship's axes and composed z-y-x here; the ship's heading in the arm's frame (the
bow's direction, +pi/2 with the bow along +y) turns it into the arm's frame. The moored-ship model's
``ShipMotion.flange_angles`` are first-order roll and pitch and the yaw off the reference heading: at their few
degrees, any order of composition differs from this one by second-order terms only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from loadarm.arm.plots import swivel_figure
from loadarm.results import Metric, Result
from loadarm.vocab import SWIVEL_FACE_TABLE

__all__ = ["SwivelTrack", "swivel_track", "rot_x", "rot_y", "rot_z", "ship_rotation", "tip_rotation", "coupler_rotation", "swivel_angles",
           "SwivelAngles", "swivel_margins"]


def _rot(angle, i: int, j: int) -> np.ndarray:
    """Rotations by ``angle`` (any shape) in the plane of axes ``i`` and ``j``: shape ``angle.shape + (3, 3)``."""
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    out = np.zeros(a.shape + (3, 3))
    k = 3 - i - j
    out[..., k, k] = 1.0
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    return out


def rot_x(angle) -> np.ndarray:
    """Rotation about x, vectorised: ``(..., 3, 3)``.

    Parameters
    ----------
    angle : float or ndarray
        rad.

    Returns
    -------
    ndarray
    """
    return _rot(angle, 1, 2)


def rot_y(angle) -> np.ndarray:
    """Rotation about y, vectorised: ``(..., 3, 3)``.

    Parameters
    ----------
    angle : float or ndarray
        rad.

    Returns
    -------
    ndarray
    """
    return _rot(angle, 2, 0)


def rot_z(angle) -> np.ndarray:
    """Rotation about z, vectorised: ``(..., 3, 3)``.

    Parameters
    ----------
    angle : float or ndarray
        rad.

    Returns
    -------
    ndarray
    """
    return _rot(angle, 0, 1)


def ship_rotation(roll, pitch, yaw, heading: float = np.pi / 2) -> np.ndarray:
    """The ship's rotation at the manifold, in the arm's frame.

    ``R = Rz(h) Rz(yaw) Ry(pitch) Rx(roll) Rz(h)^T``: the z-y-x rotation in the ship's axes (x to the bow, y to
    port, z up), seen from the arm's frame, in which the bow points along ``heading``.

    Parameters
    ----------
    roll, pitch, yaw : float or ndarray
        rad, broadcast together.
    heading : float
        The bow's direction in the arm's frame, rad from +x towards +y (+pi/2: the bow along +y and, the ship
        lying at +x, its port side alongside).

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    roll, pitch, yaw = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (roll, pitch, yaw)))
    h = rot_z(heading)
    return h @ rot_z(yaw) @ rot_y(pitch) @ rot_x(roll) @ h.T


def tip_rotation(phi, alpha, beta) -> np.ndarray:
    """The outboard arm's tip frame: ``Rz(phi) Ry(alpha - beta)``.

    Parameters
    ----------
    phi, alpha, beta : float or ndarray
        Slew, inboard and elbow angles, rad.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    phi, alpha, beta = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (phi, alpha, beta)))
    return rot_z(phi) @ rot_y(alpha - beta)


def coupler_rotation(phi, alpha, beta, s1, s2, s3) -> np.ndarray:
    """The coupler's orientation from the arm's joints and the three swivels (forward kinematics).

    Parameters
    ----------
    phi, alpha, beta : float or ndarray
        Slew, inboard and elbow angles, rad.
    s1, s2, s3 : float or ndarray
        Swivel angles, rad (about the hinge axis, the drop, the flange's normal).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Columns: the flange's normal, the coupler's lateral axis, its up axis, in the arm's frame.
    """
    return tip_rotation(phi, alpha, beta) @ rot_y(s1) @ rot_z(s2) @ rot_x(s3)


@dataclass(frozen=True, slots=True)
class SwivelAngles:
    """The three swivel angles, rad; unpacks as ``s1, s2, s3``."""

    s1: np.ndarray
    s2: np.ndarray
    s3: np.ndarray

    def __iter__(self):
        return iter((self.s1, self.s2, self.s3))


def swivel_angles(phi, alpha, beta, roll=0.0, pitch=0.0, yaw=0.0, *, heading: float = np.pi / 2,
                  coupler: np.ndarray | None = None, rotation: np.ndarray | None = None) -> SwivelAngles:
    """The three swivel angles that put the coupler on the ship's flange (inverse of :func:`coupler_rotation`).

    The coupler's orientation is the ship's rotation applied to its orientation at rest
    (``coupler``, default: the arm's frame, the flange's normal along +x, upright). The swivel chain's rotation is
    ``M = (Rz(phi) Ry(gamma))^T R`` and its y-z-x angles are read off in closed form:
    ``s2 = atan2(M10, hypot(M00, M20))``, ``s1 = atan2(-M20, M00)``, ``s3 = atan2(-M12, M11)``.

    Parameters
    ----------
    phi, alpha, beta : float or ndarray
        Slew, inboard and elbow angles, rad.
    roll, pitch, yaw : float or ndarray
        The ship's rotation at the manifold, rad (in its own axes).
    heading : float
        The ship's bow direction in the arm's frame, rad (:func:`ship_rotation`).
    coupler : ndarray (3, 3), optional
        The coupler's orientation with the ship at rest.
    rotation : ndarray (..., 3, 3), optional
        :func:`ship_rotation` of ``roll, pitch, yaw, heading``, already computed (the bank's arms share it);
        ``roll``, ``pitch``, ``yaw`` and ``heading`` are then not read.

    Returns
    -------
    SwivelAngles
        Each of the broadcast shape of the inputs.
    """
    target = ship_rotation(roll, pitch, yaw, heading) if rotation is None else np.asarray(rotation, dtype=float)
    if coupler is not None:
        target = target @ np.asarray(coupler, dtype=float)
    m = np.swapaxes(tip_rotation(phi, alpha, beta), -1, -2) @ target
    s2 = np.arctan2(m[..., 1, 0], np.hypot(m[..., 0, 0], m[..., 2, 0]))
    s1 = np.arctan2(-m[..., 2, 0], m[..., 0, 0])
    s3 = np.arctan2(-m[..., 1, 2], m[..., 1, 1])
    return SwivelAngles(s1, s2, s3)


def swivel_margins(angles: SwivelAngles, limits) -> np.ndarray:
    """Margins to the swivels' travel limits, rad, in the order of :data:`loadarm.vocab.SWIVEL_FACE_TABLE`.

    Parameters
    ----------
    angles : SwivelAngles
        Swivel angles, rad.
    limits : sequence of (float, float)
        Each swivel's (lower, upper) limit, rad.

    Returns
    -------
    ndarray, shape (..., 6)
        ``upper - s`` and ``s - lower`` for swivels 1, 2, 3: negative past a limit.
    """
    cols = []
    for s, (lo, hi) in zip(angles, limits, strict=True):
        cols += [hi - np.asarray(s), np.asarray(s) - lo]
    return np.stack(np.broadcast_arrays(*cols), axis=-1)


@dataclass(frozen=True)
class SwivelTrack(Result):
    """The three swivels through a record of the ship's motion: their angles, their margins to the stops, the
    nearest face and when.

    Attributes
    ----------
    t : ndarray, shape (n,)
        s.
    angles : SwivelAngles
        Each of shape (n,), rad.
    limits : tuple of (float, float)
        Each swivel's stops, rad.
    margins : ndarray, shape (n, 6)
        In the order of :data:`loadarm.vocab.SWIVEL_FACE_TABLE`, rad.
    """

    METRICS = (
        Metric("min_margin_deg", "smallest swivel margin", "deg", ".1f", "margin"),
        Metric("nearest_face", "nearest swivel face", ""),
        Metric("at_time_s", "at", "s", ".1f"),
        Metric("swivel_ranges_deg", "swivel 1 / 2 / 3 travel used", "deg", ".1f"),
        Metric("within_travel", "within travel", ""),
    )

    t: np.ndarray
    angles: SwivelAngles
    limits: tuple[tuple[float, float], ...]
    margins: np.ndarray

    @property
    def nearest(self) -> tuple[int, int]:
        """(sample, face) of the smallest margin."""
        k = int(np.argmin(self.margins))
        return divmod(k, self.margins.shape[1])

    def _values(self) -> dict:
        i, f = self.nearest
        return {"min_margin_deg": float(np.degrees(self.margins[i, f])),
                "nearest_face": SWIVEL_FACE_TABLE[f].name, "at_time_s": float(self.t[i]),
                "swivel_ranges_deg": [float(np.degrees(np.ptp(s))) for s in self.angles],
                "within_travel": bool(self.margins[i, f] >= 0.0)}

    def _figure(self):
        return swivel_figure(self.t, self.angles, self.limits)


def swivel_track(t, q, roll, pitch, yaw, limits, *, heading: float = np.pi / 2) -> SwivelTrack:
    """The swivels through a record: the arm's joints and the ship's rotation at the manifold, sample by sample.

    Parameters
    ----------
    t : array_like, shape (n,)
        s.
    q : array_like, shape (n, 3) or (3,)
        Slew, inboard, elbow angles, rad (one pose: held).
    roll, pitch, yaw : array_like, shape (n,)
        rad.
    limits : sequence of (float, float)
        Each swivel's stops, rad.
    heading : float
        The ship's bow direction in the arm's frame, rad.

    Returns
    -------
    SwivelTrack
    """
    t = np.asarray(t, dtype=float)
    q = np.broadcast_to(np.asarray(q, dtype=float), t.shape + (3,))
    angles = swivel_angles(q[:, 0], q[:, 1], q[:, 2], roll, pitch, yaw, heading=heading)
    limits = tuple((float(lo), float(hi)) for lo, hi in limits)
    return SwivelTrack(t, angles, limits, swivel_margins(angles, limits))
