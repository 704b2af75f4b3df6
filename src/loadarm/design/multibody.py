"""Independent multibody verification in MuJoCo (the paper's ADAMS check, Section 4, Fig. 8).

:func:`build_mjcf` writes an MJCF model of the arm from the same installation
the rest of loadarm uses. MuJoCo's frame: ``x`` towards the ship, ``z`` up, the
arm in the ``x-z`` plane, hinges about ``y``. Bodies and joints:

* ``riser`` (world geometry), inboard hinge at ``(0, 0, a)``;
* ``inboard`` body, joint ``alpha`` about ``+y`` (so the arm direction is
  ``(sin alpha, cos alpha)``, exactly the paper's alpha), with the inboard pipe,
  the elbow lump and the primary counterweight;
* ``outboard`` body at the elbow, joint ``beta`` about ``-y`` with the pipe
  along ``-z``, so the joint value *is* the paper's beta; it carries the
  outboard pipe and the ``coupler``;
* ``lever``, the pantograph lever at the riser top carrying the secondary
  counterweight; in the kinematic model a fixed-tendon equality
  ``lever - alpha + beta = 0`` plays the parallelogram linkage;
* four pin sites at the mounting points of paper Fig. 5 and two spatial
  tendons between them, ``cylinder1`` and ``cylinder2``: MuJoCo's own geometry
  gives the cylinder lengths (``ten_length``) and moment arms (tendon Jacobian).

:func:`verify_kinematics` forces the coupler along the straight line with a
mocap body and a ``connect`` equality, steps the mechanism to rest at every
sample, and reads alpha, beta and the cylinder lengths from the simulated
mechanism. :func:`inverse_dynamics` runs ``mj_inverse``.

``mujoco`` is imported here only, so the rest of loadarm starts fast.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING
from xml.sax.saxutils import quoteattr

import numpy as np

from loadarm.arm.actuators import cylinder_lengths
from loadarm.arm.dynamics import G, MassModel, mass_model
from loadarm.arm.geometry import Arm, Mounting
from loadarm.arm.kinematics import inverse
from loadarm.design.plots import verification_figure
from loadarm.design.trajectory import Plan
from loadarm.results import Result

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["build_mjcf", "load_model", "VerificationResult", "verify_kinematics", "inverse_dynamics",
           "mujoco_moment_arms", "VERIFY_SAMPLES"]

#: Samples of the approach ``loadarm verify`` checks by default (the report checks its own plans' samples; README
#: quotes each figure with its sampling).
VERIFY_SAMPLES = 201

_SETTLE_STEPS = 300
_CONVERGED_M = 1e-8


def _mujoco():
    try:
        import mujoco
    except ImportError as exc:  # pragma: no cover - mujoco is a declared dependency
        raise RuntimeError("the MuJoCo Python package is needed for multibody verification: pip install mujoco") from exc
    return mujoco


def _f(v: float) -> str:
    return repr(float(v))


def build_mjcf(arm: Arm, mount: Mounting, masses: MassModel, *, kinematic: bool = False,
               gravity: float = G, timestep: float = 1e-3) -> str:
    """MJCF text of the arm.

    Parameters
    ----------
    arm : Arm
        Link lengths, m.
    mount : Mounting
        Cylinder pin distances, m.
    masses : MassModel
        Lumps (each becomes a body welded to its link, with its own inertia).
    kinematic : bool
        If True add the mocap target, the coupler ``connect`` equality and the
        pantograph tendon equality, and switch gravity off (for the forced
        motion of :func:`verify_kinematics`).
    gravity : float
        Gravitational acceleration for the dynamic model, m/s^2.
    timestep : float
        Simulation step, s.

    Returns
    -------
    str
        A complete MJCF document (open it in MuJoCo's viewer to inspect).
    """
    a, b, c = arm.a, arm.b, arm.c
    g = 0.0 if kinematic else gravity
    by_link: dict[str, list] = {"inboard": [], "outboard": [], "lever": []}
    for lump in masses.lumps:
        if lump.mass > 0:
            by_link[lump.link].append(lump)

    def children(link: str, sign: float) -> str:
        out = []
        for lump in by_link[link]:
            out.append(f'<body name={quoteattr(lump.name)} pos="0 0 {_f(sign * lump.offset)}">'
                       f'<inertial pos="0 0 0" mass="{_f(lump.mass)}" diaginertia="{_f(max(lump.inertia, 1e-6))} '
                       f'{_f(max(lump.inertia, 1e-6))} {_f(max(lump.inertia * 1e-3, 1e-6))}"/>'
                       f'<geom type="sphere" size="0.25" contype="0" conaffinity="0" mass="0" rgba="0.4 0.4 0.4 1"/>'
                       '</body>')
        return "\n        ".join(out)

    lever = ""
    if by_link["lever"]:
        d2 = by_link["lever"][0].offset
        lever = f"""
    <body name="lever" pos="0 0 {_f(a)}">
      <joint name="lever" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 {_f(d2)}" size="0.05" contype="0" conaffinity="0" mass="0"/>
      {children("lever", 1.0)}
    </body>"""
    mocap = ""
    equality = ""
    tendon_fixed = ""
    if kinematic:
        # the connect anchor is resolved in the reference pose (all joints 0: outboard folded back along
        # the inboard arm, coupler at (0, 0, a + b - c)), so the target starts exactly there
        mocap = (f'<body name="target" mocap="true" pos="0 0 {_f(a + b - c)}"><geom type="sphere" size="0.1" '
                 'contype="0" conaffinity="0" rgba="1 0 0 0.5"/></body>')
        equality = ('<connect name="coupler_on_line" body1="coupler_tip" body2="target" anchor="0 0 0" '
                    'solref="0.004 1" solimp="0.99 0.995 0.001"/>')
        if lever:
            tendon_fixed = ('<fixed name="pantograph"><joint joint="lever" coef="1"/><joint joint="alpha" coef="-1"/>'
                            '<joint joint="beta" coef="1"/></fixed>')
            equality += '<tendon tendon1="pantograph" solref="0.004 1" solimp="0.99 0.995 0.001"/>'
    return f"""<mujoco model="loadarm">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{_f(timestep)}" gravity="0 0 {_f(-g)}" integrator="implicitfast"/>
  <worldbody>
    <geom name="riser" type="capsule" fromto="0 0 0 0 0 {_f(a)}" size="0.3" contype="0" conaffinity="0"/>
    <site name="pin_riser" pos="0 0 {_f(a - mount.a1)}" size="0.05"/>
    <body name="inboard" pos="0 0 {_f(a)}">
      <joint name="alpha" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 {_f(b)}" size="0.2" contype="0" conaffinity="0" mass="0"/>
      <site name="pin_inboard1" pos="0 0 {_f(mount.b1)}" size="0.05"/>
      <site name="pin_inboard2" pos="0 0 {_f(b - mount.b2)}" size="0.05"/>
      {children("inboard", 1.0)}
      <body name="outboard" pos="0 0 {_f(b)}">
        <joint name="beta" type="hinge" axis="0 -1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 {_f(-c)}" size="0.2" contype="0" conaffinity="0" mass="0"/>
        <site name="pin_outboard" pos="0 0 {_f(-mount.c2)}" size="0.05"/>
        {children("outboard", -1.0)}
        <body name="coupler_tip" pos="0 0 {_f(-c)}">
          <inertial pos="0 0 0" mass="1e-6" diaginertia="1e-9 1e-9 1e-9"/>
          <site name="coupler" pos="0 0 0" size="0.08"/>
        </body>
      </body>
    </body>{lever}
    {mocap}
  </worldbody>
  <tendon>
    <spatial name="cylinder1" width="0.04"><site site="pin_riser"/><site site="pin_inboard1"/></spatial>
    <spatial name="cylinder2" width="0.04"><site site="pin_inboard2"/><site site="pin_outboard"/></spatial>
    {tendon_fixed}
  </tendon>
  <equality>{equality}</equality>
</mujoco>
"""


def load_model(xml: str):
    """Compile MJCF text into an immutable ``mujoco.MjModel``.

    Parameters
    ----------
    xml : str
        MJCF document.

    Returns
    -------
    mujoco.MjModel
    """
    return _mujoco().MjModel.from_xml_string(xml)


@dataclass(frozen=True)
class VerificationResult(Result):
    """Closed form against MuJoCo, sample by sample.

    Arrays have shape ``(n,)``; angles in rad, lengths in m.
    """

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    alpha_cf: np.ndarray
    beta_cf: np.ndarray
    r1_cf: np.ndarray
    r2_cf: np.ndarray
    alpha_mj: np.ndarray
    beta_mj: np.ndarray
    r1_mj: np.ndarray
    r2_mj: np.ndarray
    tip_error: np.ndarray

    @property
    def max_angle_error_deg(self) -> float:
        """Largest |alpha| or |beta| difference, degrees."""
        return float(np.degrees(max(np.max(np.abs(self.alpha_mj - self.alpha_cf)),
                                    np.max(np.abs(self.beta_mj - self.beta_cf)))))

    @property
    def max_length_error_mm(self) -> float:
        """Largest cylinder-length difference, mm."""
        return float(1e3 * max(np.max(np.abs(self.r1_mj - self.r1_cf)), np.max(np.abs(self.r2_mj - self.r2_cf))))

    def _values(self) -> dict:
        """Headline differences, JSON-friendly."""
        return {
            "samples": int(self.t.size),
            "max_alpha_diff_deg": float(np.degrees(np.max(np.abs(self.alpha_mj - self.alpha_cf)))),
            "max_beta_diff_deg": float(np.degrees(np.max(np.abs(self.beta_mj - self.beta_cf)))),
            "max_r_ac1_diff_mm": float(1e3 * np.max(np.abs(self.r1_mj - self.r1_cf))),
            "max_r_ac2_diff_mm": float(1e3 * np.max(np.abs(self.r2_mj - self.r2_cf))),
            "max_tip_off_line_mm": float(1e3 * np.max(self.tip_error)),
            "max_angle_diff_deg": self.max_angle_error_deg,
            "max_length_diff_mm": self.max_length_error_mm,
        }

    def _figure(self):

        return verification_figure(self)


def verify_kinematics(model: ArmModel, plan: Plan, *, arm: Arm | None = None,
                      mount: Mounting | None = None) -> VerificationResult:
    """Force MuJoCo's arm along a plan's coupler path and compare with the closed form.

    At every sample the mocap target moves to the planned coupler position and
    the constrained mechanism is stepped until it is at rest on the target
    (gravity off: a pure kinematic check). The angles are MuJoCo's joint
    values, the cylinder lengths MuJoCo's tendon lengths between the pin
    sites.

    Parameters
    ----------
    model : ArmModel
        The installation (mass model, mounting).
    plan : Plan
        The planned approach; its ``x``, ``y`` are the targets.
    arm, mount : optional
        Override the configured geometry.

    Returns
    -------
    VerificationResult

    Raises
    ------
    RuntimeError
        If the mechanism fails to settle on a target (a constraint that
        cannot be met), naming the sample.
    """
    mujoco = _mujoco()
    arm = arm or model.arm
    mount = mount or model.mount
    model = load_model(build_mjcf(arm, mount, mass_model(model, arm=arm), kinematic=True))
    data = mujoco.MjData(model)
    ja, jb = model.joint("alpha").qposadr[0], model.joint("beta").qposadr[0]
    has_lever = model.njnt == 3
    jl = model.joint("lever").qposadr[0] if has_lever else None
    t1, t2 = model.tendon("cylinder1").id, model.tendon("cylinder2").id
    site = model.site("coupler").id
    # a rough elbow-up starting guess; MuJoCo pulls the arm onto the line from there
    data.qpos[ja], data.qpos[jb] = 0.3, 0.5
    if has_lever:
        data.qpos[jl] = data.qpos[ja] - data.qpos[jb]
    n = plan.t.size
    out = {k: np.empty(n) for k in ("alpha", "beta", "r1", "r2", "err")}
    for i in range(n):
        data.mocap_pos[0] = (plan.x[i], 0.0, plan.y[i])
        target = np.array([plan.x[i], 0.0, plan.y[i]])
        for _ in range(20):
            mujoco.mj_step(model, data, nstep=_SETTLE_STEPS // 10 if i else _SETTLE_STEPS)
            err = float(np.linalg.norm(data.site_xpos[site] - target))
            if err < _CONVERGED_M and float(np.max(np.abs(data.qvel))) < 1e-7:
                break
        else:
            raise RuntimeError(f"MuJoCo arm did not settle on sample {i} ({plan.x[i]:.3f}, {plan.y[i]:.3f}) m: "
                               f"coupler {err * 1e3:.3f} mm off the target")
        out["alpha"][i] = data.qpos[ja]
        out["beta"][i] = data.qpos[jb]
        out["r1"][i] = data.ten_length[t1]
        out["r2"][i] = data.ten_length[t2]
        out["err"][i] = err
    q = inverse(arm, plan.x, plan.y)
    r1, r2 = cylinder_lengths(mount, q.alpha, q.beta)
    return VerificationResult(plan.t, plan.x, plan.y, q.alpha, q.beta, r1, r2, out["alpha"], out["beta"],
                              out["r1"], out["r2"], out["err"])


def inverse_dynamics(masses: MassModel, mount: Mounting, alpha, beta, alpha_dot, beta_dot, alpha_ddot, beta_ddot,
                     *, gravity: float = G) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques from MuJoCo's ``mj_inverse`` (independent of :mod:`loadarm.arm.dynamics`).

    The pantograph lever is driven with ``lever = alpha - beta`` and its torque
    is carried to the two joints by virtual work (``tau_alpha += tau_lever``,
    ``tau_beta -= tau_lever``), which is exact for an ideal massless linkage.

    Parameters
    ----------
    masses : MassModel
        Mass model (with its arm).
    mount : Mounting
        Pin distances (only for the pin sites).
    alpha, beta, alpha_dot, beta_dot, alpha_ddot, beta_ddot : ndarray, shape (n,)
        Motion, rad, rad/s, rad/s^2.
    gravity : float
        Gravitational acceleration, m/s^2.

    Returns
    -------
    tau_alpha, tau_beta : ndarray, shape (n,)
        Joint torques, N m.
    """
    mujoco = _mujoco()
    model = load_model(build_mjcf(masses.arm, mount, masses, gravity=gravity))
    data = mujoco.MjData(model)
    ja, jb = model.joint("alpha").dofadr[0], model.joint("beta").dofadr[0]
    jl = model.joint("lever").dofadr[0] if model.njnt == 3 else None
    arrs = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (alpha, beta, alpha_dot, beta_dot,
                                                                        alpha_ddot, beta_ddot)))
    a, b, ad, bd, add, bdd = (v.ravel() for v in arrs)
    ta = np.empty(a.size)
    tb = np.empty(a.size)
    for i in range(a.size):
        data.qpos[ja], data.qpos[jb] = a[i], b[i]
        data.qvel[ja], data.qvel[jb] = ad[i], bd[i]
        data.qacc[ja], data.qacc[jb] = add[i], bdd[i]
        if jl is not None:
            data.qpos[jl], data.qvel[jl], data.qacc[jl] = a[i] - b[i], ad[i] - bd[i], add[i] - bdd[i]
        mujoco.mj_inverse(model, data)
        f = data.qfrc_inverse
        ta[i] = f[ja] + (f[jl] if jl is not None else 0.0)
        tb[i] = f[jb] - (f[jl] if jl is not None else 0.0)
    return ta.reshape(arrs[0].shape), tb.reshape(arrs[0].shape)


def mujoco_moment_arms(arm: Arm, mount: Mounting, masses: MassModel, alpha, beta) -> tuple[np.ndarray, np.ndarray]:
    """Cylinder moment arms ``d r_ac / d q`` from MuJoCo's tendon Jacobian.

    Parameters
    ----------
    arm : Arm
        Link lengths.
    mount : Mounting
        Pin distances.
    masses : MassModel
        Mass model (only to build a valid model).
    alpha, beta : ndarray, shape (n,)
        Joint angles, rad.

    Returns
    -------
    h1, h2 : ndarray, shape (n,)
        ``d r_ac1 / d alpha`` and ``d r_ac2 / d beta``, m.
    """
    mujoco = _mujoco()
    model = load_model(build_mjcf(arm, mount, masses))
    data = mujoco.MjData(model)
    ja, jb = model.joint("alpha").qposadr[0], model.joint("beta").qposadr[0]
    da, db = model.joint("alpha").dofadr[0], model.joint("beta").dofadr[0]
    t1, t2 = model.tendon("cylinder1").id, model.tendon("cylinder2").id
    a = np.atleast_1d(np.asarray(alpha, dtype=float))
    b = np.atleast_1d(np.asarray(beta, dtype=float))
    h1 = np.empty(a.size)
    h2 = np.empty(a.size)
    dense = np.zeros((model.ntendon, model.nv))
    for i in range(a.size):
        data.qpos[ja], data.qpos[jb] = a[i], b[i]
        mujoco.mj_forward(model, data)
        sparse = next((o for o in (model, data) if hasattr(o, "ten_J_rownnz")), None)
        if sparse is not None:       # MuJoCo >= 3.3 stores the tendon Jacobian sparse
            mujoco.mju_sparse2dense(dense, data.ten_J, sparse.ten_J_rownnz, sparse.ten_J_rowadr, sparse.ten_J_colind)
        else:  # pragma: no cover - dense tendon Jacobian in older MuJoCo
            dense[:] = np.asarray(data.ten_J).reshape(model.ntendon, model.nv)
        h1[i] = dense[t1, da]
        h2[i] = dense[t2, db]
    return h1, h2
