"""The faces of the attached arm's envelope: where a coupler on the ship's flange stops being safe.

While the coupler is on the flange the ship moves the arm. It is overstretched when the flange leaves the
arm's reach or drives a joint past its range: the elbow angle ``beta`` past cylinder 2's stroke end (or the
fully stretched arm) or below its retracted end (the coupler pushed towards the jetty), the inboard angle
``alpha`` past either end of cylinder 1's stroke (alpha from the upward vertical: the flange too low at its
largest, too high at its smallest), or the slew past its limit
either way. :func:`face_margins` measures every face at once, vectorised, in the face's own coordinate; the
guidance monitor, the design check (:mod:`loadarm.design.check`) and the run's overstretch detection all use it.
The faces' codes and words are declared once, in :mod:`loadarm.vocab`.
"""

from __future__ import annotations

import math

import numpy as np

from loadarm.arm.slew import inverse3d
from loadarm.vocab import FACE_LABELS, FACES

__all__ = ["FACES", "FACE_LABELS", "face_margins", "first_face", "past_a_face", "past_a_face_at",
           "breakout_distance", "ray_crossing", "RAY_REACH", "RAY_STEP"]

#: The farthest a ray from the flange is walked, m (beyond any arm's reach).
RAY_REACH = 40.0
#: A ray's sampling before the bisection, m.
RAY_STEP = 0.01


def face_margins(model, x, y, z, *, q=None) -> np.ndarray:
    """Signed margin of coupler positions to every face, in the face's own coordinate (rad).

    Parameters
    ----------
    model : ArmModel
        Arm and joint limits.
    x, y, z : float or ndarray
        Coupler positions, m (broadcast together).
    q : Joints3D, optional
        ``inverse3d(model.arm, x, y, z, check=False)`` when the caller has it already (not computed again).

    Returns
    -------
    ndarray, shape ``broadcast + (6,)``
        Margins in the order of :data:`FACES`: positive inside, zero on the face, negative past it. A position
        out of the arm's reach is ``-inf`` on the ``beta_max`` face (beyond the stretched arm) or on the
        ``beta_min`` face (inside the folded arm), and ``+inf`` on the others.
    """
    arm, lim = model.arm, model.joint_limits
    if q is None:
        q = inverse3d(arm, x, y, z, check=False)
    phi, alpha, beta = (np.asarray(v, dtype=float) for v in (q.phi, q.alpha, q.beta))
    out = np.stack([lim.beta[1] - beta, beta - lim.beta[0], lim.alpha[1] - alpha, alpha - lim.alpha[0],
                    lim.phi[1] - phi, phi - lim.phi[0]], axis=-1)
    bad = np.isnan(beta)
    if np.any(bad):
        r = np.hypot(np.hypot(x, y), np.asarray(z, dtype=float) - arm.a)
        r = np.broadcast_to(r, bad.shape)
        far = bad & (r >= 0.5 * (arm.r_min + arm.r_max))
        out[bad] = np.inf
        out[far, 0] = -np.inf
        out[bad & ~far, 1] = -np.inf
    return out


def first_face(margins: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Whether each position is past a face, and which (the one it is farthest past).

    Parameters
    ----------
    margins : ndarray, shape ``(..., 6)``
        From :func:`face_margins`.

    Returns
    -------
    outside : ndarray of bool, shape ``(...)``
    face : ndarray of int, shape ``(...)``
        Index into :data:`FACES` of the smallest margin.
    """
    face = np.argmin(margins, axis=-1)
    return np.take_along_axis(margins, face[..., None], axis=-1)[..., 0] < 0, face


def past_a_face(phi, alpha, beta, phi_range, alpha_range, beta_range):
    """Whether joint angles are past a face: the rule of :func:`face_margins` and :func:`first_face` (a margin
    below zero, NaN unreachable), on plain floats or arrays alike: the operability kernel compiles it with numba
    for its per-sample loop, the envelope's ray marches call it on arrays (:func:`past_a_face_at`); a test holds
    it to the vectorised pair.

    Parameters
    ----------
    phi, alpha, beta : float or ndarray
        rad.
    phi_range, alpha_range, beta_range : tuple of float
        The joint limits, rad.

    Returns
    -------
    bool or ndarray of bool
    """
    return np.logical_not((beta_range[0] <= beta) & (beta <= beta_range[1]) & (alpha_range[0] <= alpha)
                          & (alpha <= alpha_range[1]) & (phi_range[0] <= phi) & (phi <= phi_range[1]))


def past_a_face_at(model, x, y, z) -> np.ndarray:
    """Whether coupler positions are past a face (``first_face(face_margins(...))[0]`` without the margins:
    found, stacking six margins and taking their least was a third of every ray march over the envelope).

    Parameters
    ----------
    model : ArmModel
    x, y, z : float or ndarray
        m.

    Returns
    -------
    ndarray of bool
    """
    q = inverse3d(model.arm, x, y, z, check=False)
    lim = model.joint_limits
    return np.asarray(past_a_face(q.phi, q.alpha, q.beta, tuple(lim.phi), tuple(lim.alpha), tuple(lim.beta)))


def breakout_distance(t, speed: float, accel: float) -> np.ndarray:
    """Distance a ship covers in time ``t`` breaking out from rest at ``accel`` up to ``speed``.

    Parameters
    ----------
    t : float or ndarray
        Time since the break-out, s (>= 0).
    speed : float
        Drift speed reached, m/s (>= 0).
    accel : float
        Break-out acceleration, m/s^2 (> 0; ``inf`` for a ship already at speed).

    Returns
    -------
    ndarray
        ``a t^2 / 2`` until ``t = speed / accel``, then ``speed t - speed^2 / (2 accel)``, m.
    """
    t = np.asarray(t, dtype=float)
    if math.isinf(accel):
        return speed * t
    t_acc = speed / accel
    return np.where(t < t_acc, 0.5 * accel * t * t, speed * t - 0.5 * speed * t_acc)


def ray_crossing(p0: np.ndarray, d: np.ndarray, outside) -> float | None:
    """Smallest distance along a ray at which a condition first holds: the design check's, alarm design's and
    the operability table's walk from the flange (one routine for all three).

    Parameters
    ----------
    p0 : ndarray, shape (3,)
        Start, m.
    d : ndarray, shape (3,)
        Unit direction.
    outside : callable
        ``outside(points)`` for points of shape (N, 3): a boolean array (e.g. past a face).

    Returns
    -------
    float or None
        The distance in [0, :data:`RAY_REACH`] m to 1e-6 m (sampled at :data:`RAY_STEP`, then bisected), None if
        the condition never holds on the ray.
    """
    s = np.arange(0.0, RAY_REACH + RAY_STEP, RAY_STEP)
    pts = p0 + s[:, None] * d
    hit = np.flatnonzero(outside(pts))
    if hit.size == 0:
        return None
    i = int(hit[0])
    if i == 0:
        return 0.0
    lo, hi = float(s[i - 1]), float(s[i])
    while hi - lo > 1e-6:
        mid = 0.5 * (lo + hi)
        if bool(outside((p0 + mid * d)[None])[0]):
            hi = mid
        else:
            lo = mid
    return hi
