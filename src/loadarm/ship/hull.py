"""A ship-like parametric hull from the main dimensions, as a closed panel mesh (issue 12, item 2).

The half-breadth is a product of a waterline shape and a section shape,

    y(x, z) = B/2 * f(x) * g(z),   f(x) = 1 in the parallel midbody (:func:`parallel_midbody`), (1 - u^p)^(1/2)
                                   towards the ends,
                                   g(z) = (1 - (1 - z/T)^n)^(1/n) below the waterline (n = 10: a full midship
                                   section with a round bilge), 1 above it (wall sides up to the deck),

with u the distance into the entrance or run over its length. ``p`` is solved so that the displaced volume at
the draft gives the ship's block coefficient (``displacement / (rho L B T)``), so the hull carries the ship's
displacement, not a box's. The mesh spans keel to deck, so it crosses the waterline (a BEM solver clips it; a
hull whose top face lies on the waterline has no waterplane for hydrostatics). Vertices are in the ship frame
of :mod:`loadarm.params.berth` (x forward of midships, y to port, z above the keel).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["HullMesh", "hull_mesh", "parallel_midbody", "SECTION_EXPONENT", "PARALLEL_MIDBODY"]

#: Section-shape exponent n: midship section coefficient of the shape, about 0.98 (full, round bilge).
SECTION_EXPONENT = 10.0
#: Length of the parallel midbody as a fraction of L for full ships (Cb >= 0.7: large tankers and LNG carriers,
#: 0.3-0.5); finer ships get less (:func:`parallel_midbody`).
PARALLEL_MIDBODY = 0.4


def parallel_midbody(cb: float) -> float:
    """Parallel-midbody fraction of the length for a block coefficient: :data:`PARALLEL_MIDBODY` from Cb 0.7,
    falling linearly to none at Cb 0.5 (finer ships have short or no parallel midbody).

    Parameters
    ----------
    cb : float

    Returns
    -------
    float
    """
    return PARALLEL_MIDBODY * min(max((cb - 0.5) / 0.2, 0.0), 1.0)


@dataclass(frozen=True)
class HullMesh:
    """A closed quadrilateral panel mesh of the hull.

    Attributes
    ----------
    vertices : ndarray, shape (V, 3)
        Ship frame, m.
    faces : ndarray, shape (F, 4)
        Vertex indices, counter-clockwise seen from outside (normals point out of the hull).
    p : float
        The waterline-shape exponent solved for the block coefficient.
    midbody : float
        The parallel midbody's fraction of the length.
    """

    vertices: np.ndarray
    faces: np.ndarray
    p: float
    midbody: float

    def volume_below(self, z: float) -> float:
        """Volume enclosed below the plane at height ``z`` (divergence theorem on the panels clipped at ``z``,
        exact for the mesh when ``z`` is one of its z levels), m^3.

        Parameters
        ----------
        z : float
            Height above the keel, m.

        Returns
        -------
        float
        """
        v = self.vertices[self.faces]                        # (F, 4, 3)
        zs = v[:, :, 2]
        keep = (zs.max(axis=1) <= z + 1e-9) & (zs.min(axis=1) < z - 1e-9)    # below, not in the cut plane
        q = v[keep]
        # each quad as two triangles; volume of the closed surface = sum (a . (b x c)) / 6, with the lid at z
        tri = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
        vol = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0
        # close the open top with the waterplane (normal +z): the cone from the origin over it is z * area / 3
        return float(vol + z * self.waterplane_area(z) / 3.0)

    def waterplane_area(self, z: float) -> float:
        """Area inside the hull's section at height ``z`` (trapezoidal in x), m^2.

        Parameters
        ----------
        z : float

        Returns
        -------
        float
        """
        v = self.vertices
        at = np.abs(v[:, 2] - z) < 1e-9
        pts = v[at]
        xs = np.unique(np.round(pts[:, 0], 9))
        half = np.array([pts[np.isclose(pts[:, 0], x), 1].max() for x in xs])
        return float(2.0 * np.trapezoid(half, xs))


def _f(u: np.ndarray, p: float) -> np.ndarray:
    return np.sqrt(np.clip(1.0 - u ** p, 0.0, 1.0))


def _x_shape(x: np.ndarray, length: float, p: float, midbody: float) -> np.ndarray:
    half_pm = midbody * length / 2
    u = np.clip((np.abs(x) - half_pm) / (length / 2 - half_pm), 0.0, 1.0)
    return _f(u, p)


def _g(z: np.ndarray, draft: float) -> np.ndarray:
    s = np.clip(1.0 - z / draft, 0.0, 1.0)
    return np.where(z >= draft, 1.0, (1.0 - s ** SECTION_EXPONENT) ** (1.0 / SECTION_EXPONENT))


def _solve_p(cb: float, midbody: float) -> float:
    """The exponent p whose hull has the block coefficient ``cb`` (bisection on the integral)."""
    zz = np.linspace(0.0, 1.0, 4001)
    cm = np.trapezoid(_g(zz, 1.0), zz)                    # midship section coefficient of the shape
    uu = np.linspace(0.0, 1.0, 4001)

    def cb_of(p):
        return cm * (midbody + (1 - midbody) * np.trapezoid(_f(uu, p), uu))

    lo, hi = 0.2, 60.0
    if not cb_of(lo) <= cb <= cb_of(hi):
        raise ValueError(f"a block coefficient of {cb:.3f} is outside what this hull family spans "
                         f"[{cb_of(lo):.3f}, {cb_of(hi):.3f}]")
    for _ in range(80):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if cb_of(mid) < cb else (lo, mid)
    return math.sqrt(lo * hi)


def hull_mesh(length: float, beam: float, draft: float, depth: float, block_coefficient: float, *,
              nx: int = 60, nz: int = 12) -> HullMesh:
    """Mesh a hull of these main dimensions and block coefficient, keel to deck.

    Parameters
    ----------
    length, beam, draft, depth : float
        L between perpendiculars, B, T, D, m.
    block_coefficient : float
        Cb of the loading condition (:data:`loadarm.params.berth.RHO_SEA` and the displacement give it).
    nx, nz : int
        Panels along the length and, on each side, from the keel to the draft (the sides above the draft get
        ``max(2, nz // 3)`` more).

    Returns
    -------
    HullMesh

    Raises
    ------
    ValueError
        Dimensions not positive, depth not above the draft, or a block coefficient the family cannot reach.
    """
    if not (length > 0 and beam > 0 and 0 < draft < depth):
        raise ValueError(f"need L, B > 0 and 0 < T < D, got L={length}, B={beam}, T={draft}, D={depth}")
    midbody = parallel_midbody(block_coefficient)
    p = _solve_p(block_coefficient, midbody)
    # along x: the entrance and the run cosine-spaced between the midbody's ends and the tips (the waterline's
    # slope is unbounded at both when p < 1: found by the thorough profile, where a fine hull converged at first
    # order with nodes only cosine-spaced over the whole length), the midbody uniform; z: keel to draft, to deck
    half_pm = midbody * length / 2
    n_end = max(2, round(nx * 0.35)) if midbody > 0 else nx // 2
    n_mid = max(nx - 2 * n_end, 1) if midbody > 0 else 0
    end = half_pm + (length / 2 - half_pm) * 0.5 * (1 - np.cos(np.linspace(0.0, math.pi, n_end + 1)))
    x = np.concatenate([-end[::-1], np.linspace(-half_pm, half_pm, n_mid + 1)[1:-1], end]) if n_mid else \
        np.concatenate([-end[::-1], end[1:]])
    z = np.concatenate([draft * (1 - np.cos(np.linspace(0.0, math.pi / 2, nz + 1))),
                        np.linspace(draft, depth, max(2, nz // 3) + 1)[1:]])
    X, Z = np.meshgrid(x, z, indexing="ij")                   # (nx+1, nz')
    Y = beam / 2 * _x_shape(X, length, p, midbody) * _g(Z, draft)
    ni, nk = X.shape
    port = np.stack([X, Y, Z], axis=-1).reshape(-1, 3)
    star = np.stack([X, -Y, Z], axis=-1).reshape(-1, 3)
    verts = np.concatenate([port, star])
    idx = np.arange(ni * nk).reshape(ni, nk)
    faces = []
    for i in range(ni - 1):
        for k in range(nk - 1):
            a, b, c, d = idx[i, k], idx[i + 1, k], idx[i + 1, k + 1], idx[i, k + 1]
            faces.append((a, d, c, b))                         # port side, normal +y
            faces.append((a + ni * nk, b + ni * nk, c + ni * nk, d + ni * nk))      # starboard, normal -y
    # deck lid (closes the hull at z = depth): port edge to starboard edge, normal +z
    k = nk - 1
    for i in range(ni - 1):
        a, b = idx[i, k], idx[i + 1, k]
        faces.append((a + ni * nk, b + ni * nk, b, a))
    return HullMesh(verts, np.array(faces, dtype=int), p, midbody)
