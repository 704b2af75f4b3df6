"""The triple swivel in MuJoCo: an independent route to the swivel angles (issue 31, item 2).

The arm's chain (slew, inboard, outboard) and the three swivels become hinge joints of one MuJoCo model; MuJoCo
composes the bodies' frames itself. :func:`mujoco_coupler_rotation` reads the coupler's orientation for given
joint angles (MuJoCo's forward kinematics); :func:`mujoco_swivel_angles` holds the arm's joints and solves the
three swivels that lay the coupler on a target orientation by Gauss-Newton on MuJoCo's own rotational Jacobian
(``mj_jacBody``), from zero: it shares nothing with the closed form of :func:`loadarm.arm.swivel.swivel_angles`
but the frame conventions the MJCF states (``tests/test_bank.py`` compares the two).
"""

from __future__ import annotations

import numpy as np

from loadarm.arm.geometry import Arm

__all__ = ["CHAIN", "chain_mjcf", "swivel_mjcf", "mujoco_coupler_rotation", "mujoco_swivel_angles"]

_SWIVELS = ("swivel1", "swivel2", "swivel3")
#: The chain's six hinges in MuJoCo, from the slew to the coupler: the arm's joints, then the swivels.
CHAIN = ("phi", "alpha", "beta", *_SWIVELS)


def chain_mjcf(arm: Arm, model: str, inertial: str, *, gravity: float = 0.0, inside: dict[str, str] | None = None,
               end: str = "coupler") -> str:
    """MJCF text of the arm's chain: the slew, the inboard and outboard arms and the triple swivel's three hinges
    (:data:`CHAIN`), nested bodies whose frames MuJoCo composes. The one statement of the frames' conventions, for
    the swivels' route (:func:`swivel_mjcf`) and the manifold's loads
    (:func:`loadarm.design.manifold.manifold_mjcf`).

    Parameters
    ----------
    arm : Arm
        Lengths, m.
    model : str
        The model's name.
    inertial : str
        Each body's ``<inertial>`` element.
    gravity : float
        Downwards, m/s^2.
    inside : dict, optional
        A body's name (``slew``, ``inboard``, ``outboard``, ``swivel1``, ``swivel2`` or ``end``) to more MJCF
        placed in that body after its hinge: lumps, a site, a parallel body.
    end : str
        The name of the last body, the coupler's.

    Returns
    -------
    str
    """
    a, b, c = (repr(float(v)) for v in (arm.a, arm.b, arm.c))
    more = inside or {}
    links = (("slew", "", "0 0 1"), ("inboard", f"0 0 {a}", "0 1 0"), ("outboard", f"0 0 {b}", "0 -1 0"),
             ("swivel1", f"0 0 -{c}", "0 1 0"), ("swivel2", "", "0 0 1"), (end, "", "1 0 0"))
    chain = ""
    for (body, pos, axis), joint in zip(reversed(links), reversed(CHAIN), strict=True):
        at = f' pos="{pos}"' if pos else ""
        chain = (f'<body name="{body}"{at}>{inertial}<joint name="{joint}" type="hinge" axis="{axis}"/>'
                 f'{more.get(body, "")}{chain}</body>')
    return (f'<mujoco model="{model}"><compiler angle="radian"/><option gravity="0 0 {-float(gravity)!r}"/>'
            f'<worldbody>{chain}</worldbody></mujoco>')


def swivel_mjcf(arm: Arm) -> str:
    """MJCF text of the arm with its slew and its triple swivel, kinematic only (no gravity, no masses that matter).

    Parameters
    ----------
    arm : Arm
        Lengths, m.

    Returns
    -------
    str
    """
    return chain_mjcf(arm, "triple_swivel", '<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>')


def _model(arm: Arm):
    import mujoco

    model = mujoco.MjModel.from_xml_string(swivel_mjcf(arm))
    return mujoco, model, mujoco.MjData(model)


def _addr(mujoco, model, names) -> list[int]:
    return [int(model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)]) for n in names]


def mujoco_coupler_rotation(arm: Arm, q, swivels) -> np.ndarray:
    """The coupler's orientation by MuJoCo's forward kinematics.

    Parameters
    ----------
    arm : Arm
    q : array_like, shape (n, 3)
        Slew, inboard, elbow angles, rad.
    swivels : array_like, shape (n, 3)
        Swivel angles, rad.

    Returns
    -------
    ndarray, shape (n, 3, 3)
    """
    mujoco, model, data = _model(arm)
    addr = _addr(mujoco, model, CHAIN)
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "coupler")
    qq = np.hstack([np.atleast_2d(q), np.atleast_2d(swivels)])
    out = np.empty((qq.shape[0], 3, 3))
    for i, row in enumerate(qq):
        data.qpos[addr] = row
        mujoco.mj_kinematics(model, data)
        out[i] = data.xmat[body].reshape(3, 3)
    return out


def _rotation_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """The rotation vector (world frame) that turns ``current`` into ``target``, rad."""
    r = target @ current.T
    angle = np.arccos(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0))
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    s = np.sin(angle)
    return axis / 2.0 if s < 1e-9 else axis * angle / (2.0 * s)


def mujoco_swivel_angles(arm: Arm, q, targets, *, tol: float = 1e-13, max_iter: int = 50) -> np.ndarray:
    """The swivel angles that lay the coupler on each target orientation, the arm's joints held: Gauss-Newton
    on MuJoCo's rotational Jacobian of the coupler body, from zero swivel angles.

    Parameters
    ----------
    arm : Arm
    q : array_like, shape (n, 3)
        Slew, inboard, elbow angles, rad.
    targets : array_like, shape (n, 3, 3)
        The coupler's orientations.
    tol : float
        Stop when the rotation left is below this, rad.
    max_iter : int

    Returns
    -------
    ndarray, shape (n, 3)
        Swivel angles, rad, wrapped to (-pi, pi]; NaN where it did not converge.
    """
    mujoco, model, data = _model(arm)
    arm_addr = _addr(mujoco, model, ("phi", "alpha", "beta"))
    sw_addr = _addr(mujoco, model, _SWIVELS)
    dofs = [int(model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)]) for n in _SWIVELS]
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "coupler")
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    q, targets = np.atleast_2d(q), np.asarray(targets, dtype=float).reshape(-1, 3, 3)
    out = np.full((q.shape[0], 3), np.nan)
    for i in range(q.shape[0]):
        data.qpos[:] = 0.0
        data.qpos[arm_addr] = q[i]
        for _ in range(max_iter):
            mujoco.mj_kinematics(model, data)
            mujoco.mj_comPos(model, data)
            err = _rotation_error(targets[i], data.xmat[body].reshape(3, 3))
            if np.linalg.norm(err) < tol:
                out[i] = np.angle(np.exp(1j * data.qpos[sw_addr]))
                break
            mujoco.mj_jacBody(model, data, jacp, jacr, body)
            step, *_ = np.linalg.lstsq(jacr[:, dofs], err, rcond=None)
            data.qpos[sw_addr] += step
    return out
