"""The bank's loads on the ship's manifold, checked against the allowable (issue 31, item 4).

Each arm, connected and free-wheeling, loads its presentation flange with what its counterweights leave
unbalanced, the product in its pipes (liquid arms full, the vapour return empty), the wind on its pipes, its
inertia as the ship moves it, and its swivels' friction (:mod:`loadarm.arm.manifold`, the one formula). Here:

* :func:`check_manifold_loads` (``loadarm check --bank``): every arm at its flange at the manifold's design
  position and at the four corners of its datasheet's flange box (the ship's motion envelope), the wind of
  ``manifold_loads.wind_speed`` from every direction (12) and calm, every extreme of the six joints' friction at
  rest (64): the worst of each load per arm, its utilisation of the allowable, and the alarm's event code
  (:data:`MANIFOLD_LOAD_EVENT`) for each load past its allowable.
* :func:`record_manifold_loads`: the loads through a record of the ship's 6-DoF motion at the manifold (a
  :class:`loadarm.ship.motion.ShipMotion` through :func:`motion_manifold_loads`): each flange moves with the ship
  as a rigid body, the arm follows it (inverse kinematics, rates and accelerations by second-order differences on
  the record's grid), friction against each joint's motion; the worst load per arm and when, and the alarm's
  times.
* :func:`mujoco_flange_wrench`: the independent route, the same chain of six hinge joints and the arm's lumps in
  MuJoCo, its inverse dynamics (``mj_inverse``) and its own Jacobian at the flange's face (``mj_jac``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

import numpy as np

from loadarm.arm.dynamics import G, MassModel, mass_model
from loadarm.arm.envelope import berth_box
from loadarm.arm.manifold import (
    LOAD_NAMES,
    FlangeWrench,
    coulomb,
    flange_wrench,
    friction_signs,
)
from loadarm.arm.slew import inverse3d
from loadarm.arm.swivel import ship_rotation, swivel_angles
from loadarm.design.plots import manifold_check_figure, manifold_record_figure
from loadarm.design.swivels import CHAIN, chain_mjcf
from loadarm.params.bank import Bank
from loadarm.results import Metric, Result
from loadarm.ship.loads import RHO_AIR
from loadarm.vocab import EVENTS

__all__ = [
    "LOAD_LABELS",
    "MANIFOLD_LOAD_EVENT",
    "WIND_DIRECTIONS",
    "ManifoldLoadCheck",
    "ManifoldLoadRecord",
    "allowable",
    "arm_masses",
    "berth_wind",
    "check_manifold_loads",
    "motion_manifold_loads",
    "mujoco_flange_wrench",
    "record_manifold_loads",
    "wind_coefficient",
]

#: The event code of a manifold load past its allowable (:data:`loadarm.vocab.EVENT_TABLE`).
MANIFOLD_LOAD_EVENT = EVENTS["fault.manifold_load"].code
#: The loads' words, in the order of :data:`loadarm.arm.manifold.LOAD_NAMES`.
LOAD_LABELS = ("axial force", "lateral force", "vertical force", "bending moment", "torsion moment")
#: Wind directions the design check tries (and calm).
WIND_DIRECTIONS = 12


def arm_masses(bank: Bank, i: int) -> MassModel:
    """Arm ``i``'s mass model connected: its pipes full of its installation's product on a liquid flange, empty on
    the vapour return.

    Parameters
    ----------
    bank : Bank
    i : int

    Returns
    -------
    MassModel
    """
    return mass_model(bank.models[i], fill=1.0 if bank.flanges[i].product == "liquid" else 0.0)


def wind_coefficient(bank: Bank) -> float:
    """``rho_air C_d D / 2`` of the arms' pipes, ``D`` the capsules' ``2 clearance.pipe_radius``, kg/m^2.

    Parameters
    ----------
    bank : Bank

    Returns
    -------
    float
    """
    return 0.5 * RHO_AIR * bank.file.manifold_loads.drag_coefficient * 2.0 * bank.file.clearance.pipe_radius


def allowable(bank: Bank) -> np.ndarray:
    """The allowable loads of the bank file, in the order of :data:`loadarm.arm.manifold.LOAD_NAMES`.

    Parameters
    ----------
    bank : Bank

    Returns
    -------
    ndarray, shape (5,)
        N and N m.
    """
    ml = bank.file.manifold_loads
    return np.array([getattr(ml, k) for k in LOAD_NAMES])


def _worst(loads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The largest magnitude of each load over the leading axes of ``loads (..., 5)`` and its flat index."""
    flat = np.abs(loads.reshape(-1, loads.shape[-1]))
    k = np.argmax(flat, axis=0)
    return flat[k, np.arange(flat.shape[1])], k


def _exceeded(names, worst: np.ndarray, allow: np.ndarray) -> list[dict]:
    return [{"code": MANIFOLD_LOAD_EVENT, "arm": n, "load": LOAD_NAMES[j], "value": float(worst[i, j]),
             "allowable": float(allow[j])}
            for i, n in enumerate(names) for j in range(allow.size) if worst[i, j] > allow[j]]


@dataclass(frozen=True)
class ManifoldLoadCheck(Result):
    """The bank's worst loads on its flanges over the design check's cases.

    Attributes
    ----------
    names : tuple of str
        The arms.
    cases : tuple of str
        The flange positions tried (the design case and the flange box's corners).
    allowable : ndarray, shape (5,)
        N, N m, in the order of :data:`loadarm.arm.manifold.LOAD_NAMES`.
    static : ndarray, shape (arms, 5)
        The design case, calm, no friction: the arm's unbalance and its product alone (signed).
    worst : ndarray, shape (arms, 5)
        The largest magnitude of each load over every case, wind and friction.
    governing : tuple of tuple of str
        For each arm and load, the case that gives it.
    wind_speed : float
        m/s.
    """

    METRICS = (
        Metric("max_utilisation", "flange load / allowable, largest", "", ".2f"),
        Metric("governing", "which, where", ""),
        Metric("design_vertical_force_kN", "vertical force, design case, calm", "kN", ".2f"),
        Metric("within_allowable", "within the allowable loads", ""),
    )

    names: tuple[str, ...]
    cases: tuple[str, ...]
    allowable: np.ndarray
    static: np.ndarray
    worst: np.ndarray
    governing: tuple[tuple[str, ...], ...]
    wind_speed: float

    @property
    def utilisation(self) -> np.ndarray:
        """``worst / allowable``, shape (arms, 5)."""
        return self.worst / self.allowable

    @property
    def ok(self) -> bool:
        """Every load of every arm within its allowable."""
        return bool(np.all(self.utilisation <= 1.0))

    @property
    def exceeded(self) -> list[dict]:
        """Each load past its allowable: the alarm's event code, the arm, the load, its value and the allowable."""
        return _exceeded(self.names, self.worst, self.allowable)

    def _values(self) -> dict:
        u = self.utilisation
        i, j = np.unravel_index(int(np.argmax(u)), u.shape)
        return {"max_utilisation": float(u[i, j]),
                "governing": f"{self.names[i]} {LOAD_LABELS[j]}, {self.governing[i][j]}",
                "design_vertical_force_kN": [float(v) * 1e-3 for v in self.static[:, 2]],
                "within_allowable": self.ok,
                "wind_speed_m_s": self.wind_speed,
                "arms": {n: {"worst": dict(zip(LOAD_NAMES, (float(v) for v in self.worst[k]), strict=True)),
                             "utilisation": dict(zip(LOAD_NAMES, (float(v) for v in u[k]), strict=True)),
                             "static": dict(zip(LOAD_NAMES, (float(v) for v in self.static[k]), strict=True))}
                         for k, n in enumerate(self.names)},
                "allowable": dict(zip(LOAD_NAMES, (float(v) for v in self.allowable), strict=True)),
                "exceeded": self.exceeded}

    def _figure(self):
        return manifold_check_figure(self.names, LOAD_LABELS, self.utilisation, self.static / self.allowable)


def _cases(bank: Bank, i: int) -> tuple[tuple[str, ...], np.ndarray]:
    """Arm ``i``'s flange at the design case and at its datasheet box's corners, in its own frame, m."""
    p = bank.flange_position(i)
    box = berth_box(bank.models[i].datasheet)
    names = ["design case"]
    points = [p]
    for name, x, z in box.corners():
        names.append(name)
        points.append(np.array([x, p[1], z]))
    return tuple(names), np.array(points)


def check_manifold_loads(bank: Bank, *, directions: int = WIND_DIRECTIONS) -> ManifoldLoadCheck:
    """The worst load of every arm on its flange over the design case, the flange box's corners, the wind from
    every direction and calm, and every extreme of the joints' friction at rest.

    Parameters
    ----------
    bank : Bank
    directions : int
        Wind directions tried, evenly spaced.

    Returns
    -------
    ManifoldLoadCheck
    """
    ml = bank.file.manifold_loads
    heading = math.radians(bank.file.manifold.heading_deg)
    theta = 2.0 * np.pi * np.arange(directions) / directions
    winds = np.vstack([np.zeros(3), ml.wind_speed * np.column_stack([np.cos(theta), np.sin(theta),
                                                                      np.zeros(directions)])])
    friction = ml.swivel_friction_torque * friction_signs()
    k = wind_coefficient(bank)
    statics, worsts, governing = [], [], []
    case_names: tuple[str, ...] = ()
    for i, model in enumerate(bank.models):
        case_names, pts = _cases(bank, i)
        q = np.column_stack(list(inverse3d(model.arm, pts[:, 0], pts[:, 1], pts[:, 2])))
        s = np.column_stack(list(swivel_angles(q[:, 0], q[:, 1], q[:, 2], heading=heading)))
        masses = arm_masses(bank, i)
        zero = np.zeros(3)
        statics.append(flange_wrench(masses, q[0], zero, zero, s[0], coupler_length=ml.coupler_length).loads)
        shape = (len(pts), len(winds), len(friction))
        qq = np.broadcast_to(q[:, None, None, :], shape + (3,))
        ss = np.broadcast_to(s[:, None, None, :], shape + (3,))
        loads = flange_wrench(masses, qq, zero, zero, ss, wind=winds[None, :, None, :], wind_k=k,
                              friction=friction[None, None, :, :], coupler_length=ml.coupler_length).loads
        worst, at = _worst(loads)
        worsts.append(worst)
        governing.append(tuple(_case_words(case_names, winds, ml.wind_speed, shape, int(a)) for a in at))
    return ManifoldLoadCheck(bank.names, case_names, allowable(bank), np.array(statics), np.array(worsts),
                             tuple(governing), float(ml.wind_speed))


def _case_words(cases, winds, speed: float, shape, flat: int) -> str:
    c, w, _ = np.unravel_index(flat, shape)
    if w == 0:
        return f"{cases[c]}, calm"
    to = math.degrees(math.atan2(winds[w, 1], winds[w, 0]))
    return f"{cases[c]}, wind {speed:g} m/s to {to:+.0f} deg"


@dataclass(frozen=True)
class ManifoldLoadRecord(Result):
    """The bank's loads on its flanges through a record of the ship's motion.

    Attributes
    ----------
    t : ndarray, shape (n,)
        s.
    names : tuple of str
    loads : ndarray, shape (arms, n, 5)
        In the order of :data:`loadarm.arm.manifold.LOAD_NAMES`, N and N m.
    allowable : ndarray, shape (5,)
    """

    METRICS = (
        Metric("max_utilisation", "flange load / allowable, largest over the record", "", ".2f"),
        Metric("governing", "which", ""),
        Metric("at_time_s", "when", "s", ".1f"),
        Metric("within_allowable", "within the allowable loads", ""),
    )

    t: np.ndarray
    names: tuple[str, ...]
    loads: np.ndarray
    allowable: np.ndarray

    @property
    def worst(self) -> np.ndarray:
        """The largest magnitude of each load per arm over the record, shape (arms, 5)."""
        return np.abs(self.loads).max(axis=1)

    @property
    def worst_time(self) -> np.ndarray:
        """When each arm's each load is at its worst, s, shape (arms, 5)."""
        return self.t[np.argmax(np.abs(self.loads), axis=1)]

    @property
    def exceeded(self) -> list[dict]:
        """Each load past its allowable over the record: the alarm's event code, the arm, the load, its worst value,
        the allowable, and the first time past it (s)."""
        out = _exceeded(self.names, self.worst, self.allowable)
        for e in out:
            i, j = self.names.index(e["arm"]), LOAD_NAMES.index(e["load"])
            e["first_time_s"] = float(self.t[np.argmax(np.abs(self.loads[i, :, j]) > self.allowable[j])])
        return out

    def _values(self) -> dict:
        u = self.worst / self.allowable
        i, j = np.unravel_index(int(np.argmax(u)), u.shape)
        return {"max_utilisation": float(u[i, j]), "governing": f"{self.names[i]} {LOAD_LABELS[j]}",
                "at_time_s": float(self.worst_time[i, j]), "within_allowable": bool(np.all(u <= 1.0)),
                "arms": {n: {LOAD_NAMES[k]: {"worst": float(self.worst[a, k]), "utilisation": float(u[a, k]),
                                             "time_s": float(self.worst_time[a, k])} for k in range(len(LOAD_NAMES))}
                         for a, n in enumerate(self.names)},
                "exceeded": self.exceeded}

    def _figure(self):
        return manifold_record_figure(self.t, self.names, LOAD_LABELS, self.loads / self.allowable)


def record_manifold_loads(bank: Bank, t, displacement, angles, *, wind=(0.0, 0.0, 0.0)) -> ManifoldLoadRecord:
    """The bank's loads through a record of the ship's motion at the manifold.

    Each flange moves with the ship as one rigid body: ``p_i = p_i0 + d + (R - 1) o_i``, ``p_i0`` its design
    position, ``d`` the manifold centre's displacement, ``R`` the ship's rotation
    (:func:`loadarm.arm.swivel.ship_rotation`) and ``o_i`` the flange's offset from the manifold's centre.

    Parameters
    ----------
    bank : Bank
    t : array_like, shape (n,)
        s, evenly spaced (n >= 3).
    displacement : array_like, shape (n, 3)
        The manifold centre from its design position, bank frame, m.
    angles : array_like, shape (n, 3)
        The ship's roll, pitch and yaw at the manifold, rad.
    wind : array_like, shape (3,) or (n, 3)
        The wind's velocity, bank frame, m/s.

    Returns
    -------
    ManifoldLoadRecord

    Raises
    ------
    ValueError
        Given fewer than 3 samples, an uneven or non-increasing time grid, or arrays of the wrong shape.
    """
    t = np.asarray(t, dtype=float)
    d = np.asarray(displacement, dtype=float)
    ang = np.asarray(angles, dtype=float)
    dt = np.diff(t)
    if t.ndim != 1 or t.size < 3 or d.shape != (t.size, 3) or ang.shape != (t.size, 3):
        raise ValueError(f"a record takes t (n >= 3,), displacement and angles (n, 3); got {t.shape}, {d.shape}, "
                         f"{ang.shape}")
    if not (np.all(dt > 0) and np.allclose(dt, dt[0], rtol=1e-6)):
        raise ValueError("the record's times must increase evenly")
    ml = bank.file.manifold_loads
    heading = math.radians(bank.file.manifold.heading_deg)
    rot = ship_rotation(ang[:, 0], ang[:, 1], ang[:, 2], heading)
    k = wind_coefficient(bank)
    out = []
    for i, model in enumerate(bank.models):
        f = bank.flanges[i]
        offset = np.array([0.0, f.offset, f.height])
        p = bank.flange_position(i) + d + (rot @ offset) - offset
        q = np.column_stack(list(inverse3d(model.arm, p[:, 0], p[:, 1], p[:, 2])))
        s = np.column_stack(list(swivel_angles(q[:, 0], q[:, 1], q[:, 2], ang[:, 0], ang[:, 1], ang[:, 2],
                                               heading=heading)))
        qd = np.gradient(q, t, axis=0, edge_order=2)
        qdd = np.gradient(qd, t, axis=0, edge_order=2)
        sd = np.gradient(s, t, axis=0, edge_order=2)
        friction = coulomb(ml.swivel_friction_torque, np.hstack([qd, sd]))
        out.append(flange_wrench(arm_masses(bank, i), q, qd, qdd, s, wind=wind, wind_k=k, friction=friction,
                                 coupler_length=ml.coupler_length).loads)
    return ManifoldLoadRecord(t, bank.names, np.array(out), allowable(bank))


def berth_wind(environment) -> np.ndarray:
    """The mean wind of a berth's environment as a velocity in the bank's frame (``x`` off the berth), m/s.

    Parameters
    ----------
    environment : loadarm.params.berth.Environment
        Its ``wind_speed`` and ``wind_direction_deg`` (where the wind blows to).

    Returns
    -------
    ndarray, shape (3,)
    """
    to = math.radians(environment.wind_direction_deg)
    return environment.wind_speed * np.array([math.cos(to), math.sin(to), 0.0])


def motion_manifold_loads(bank: Bank, motion, *, wind=(0.0, 0.0, 0.0), lift=(0.0, 0.0, 0.0)) -> ManifoldLoadRecord:
    """The bank's loads through a moored ship's motion (the manifold's record of :mod:`loadarm.ship.motion`).

    Parameters
    ----------
    bank : Bank
    motion : ShipMotion
        Its ``flange`` (berth frame: x off the berth, as the bank's), ``flange_reference`` and ``flange_angles``.
    wind : array_like, shape (3,) or (n, 3)
        m/s, bank frame.
    lift : array_like, shape (3,)
        A constant displacement of the manifold added to the motion's (the tide's rise), m.

    Returns
    -------
    ManifoldLoadRecord
    """
    d = (np.asarray(motion.flange, dtype=float) - np.asarray(motion.flange_reference, dtype=float)
         + np.asarray(lift, dtype=float))
    return record_manifold_loads(bank, motion.t, d, motion.flange_angles, wind=wind)


def _lumps_mjcf(masses: MassModel, link: str, sign: float) -> str:
    out = []
    for lump in masses.lumps:
        if lump.link != link or lump.mass <= 0:
            continue
        i = repr(max(float(lump.inertia), 1e-9))
        out.append(f'<body name={quoteattr("lump_" + lump.name)} pos="0 0 {sign * lump.offset!r}"><inertial pos="0 0 0" '
                   f'mass="{float(lump.mass)!r}" diaginertia="{i} {i} 1e-12"/></body>')
    return "".join(out)


def manifold_mjcf(masses: MassModel, coupler_length: float, gravity: float = G) -> str:
    """MJCF text of the connected arm: slew, inboard, outboard and the pantograph lever with their lumps (each
    lump's own inertia across its link, none along it), the triple swivel's three massless hinges, and a site on
    the flange's face (lumps named ``lump_<name>``; the coupler's body ``flange``).

    Parameters
    ----------
    masses : MassModel
    coupler_length : float
        m.
    gravity : float
        m/s^2.

    Returns
    -------
    str
    """
    tiny = '<inertial pos="0 0 0" mass="1e-9" diaginertia="1e-12 1e-12 1e-12"/>'
    lever = (f'<body name="lever" pos="0 0 {float(masses.arm.a)!r}">{tiny}<joint name="lever" type="hinge" '
             f'axis="0 1 0"/>{_lumps_mjcf(masses, "lever", 1.0)}</body>')
    return chain_mjcf(masses.arm, "manifold_loads", tiny, gravity=gravity, end="flange",
                      inside={"slew": lever, "inboard": _lumps_mjcf(masses, "inboard", 1.0),
                              "outboard": _lumps_mjcf(masses, "outboard", -1.0),
                              "flange": f'<site name="face" pos="{float(coupler_length)!r} 0 0"/>'})


def _mj_wind(mujoco, model, data, wind: np.ndarray, k: float) -> np.ndarray:
    """The wind's generalised force on MuJoCo's dofs, from the pipes' drag at their midpoints (``mj_applyFT``)."""
    qfrc = np.zeros(model.nv)
    ends = [data.body(n).xpos.copy() for n in ("inboard", "outboard", "swivel1")]
    for body, p0, p1 in (("inboard", ends[0], ends[1]), ("outboard", ends[1], ends[2])):
        axis = (p1 - p0) / np.linalg.norm(p1 - p0)
        un = wind - (wind @ axis) * axis
        force = k * np.linalg.norm(p1 - p0) * np.linalg.norm(un) * un
        mujoco.mj_applyFT(model, data, force, np.zeros(3), 0.5 * (p0 + p1), model.body(body).id, qfrc)
    return qfrc


def mujoco_flange_wrench(masses: MassModel, q, qd, qdd, s, *, wind=(0.0, 0.0, 0.0), wind_k: float = 0.0,
                         friction=0.0, coupler_length: float = 0.0, gravity: float = G) -> FlangeWrench:
    """The flange's load by MuJoCo: the independent route to :func:`loadarm.arm.manifold.flange_wrench`.

    MuJoCo's inverse dynamics (``mj_inverse``, the pantograph lever driven at ``alpha - beta`` and its torque
    carried to the two joints by virtual work) gives the joints' generalised forces; the wind's comes from
    ``mj_applyFT`` at the pipes' midpoints (MuJoCo's positions and Jacobians); MuJoCo's Jacobian at the flange's
    face site (``mj_jac``) gives the wrench there, read in the coupler body's axes (``xmat``). The swivels' rates
    are taken as zero (their massless bodies carry no inertia).

    Parameters
    ----------
    masses : MassModel
    q, qd, qdd, s : array_like, shape (n, 3)
    wind : array_like, shape (3,)
        m/s.
    wind_k : float
        kg/m^2.
    friction : float or array_like, shape (n, 6)
        N m, as they act on the arm.
    coupler_length : float
        m.
    gravity : float
        m/s^2.

    Returns
    -------
    FlangeWrench
    """
    import mujoco

    q, qd, qdd, s = (np.atleast_2d(np.asarray(v, dtype=float)) for v in (q, qd, qdd, s))
    n = q.shape[0]
    friction = np.broadcast_to(np.asarray(friction, dtype=float), (n, 6))
    wind = np.asarray(wind, dtype=float)
    model = mujoco.MjModel.from_xml_string(manifold_mjcf(masses, coupler_length, gravity))
    data = mujoco.MjData(model)
    dof = [model.joint(j).dofadr[0] for j in CHAIN]
    lever = model.joint("lever").dofadr[0]
    face = model.site("face").id
    force, moment, loads = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 5))
    for i in range(n):
        data.qpos[:] = 0.0
        data.qvel[:] = 0.0
        data.qacc[:] = 0.0
        for k, j in enumerate(dof):
            data.qpos[j] = (*q[i], *s[i])[k]
            data.qvel[j] = (*qd[i], 0.0, 0.0, 0.0)[k]
            data.qacc[j] = (*qdd[i], 0.0, 0.0, 0.0)[k]
        data.qpos[lever] = q[i, 1] - q[i, 2]
        data.qvel[lever] = qd[i, 1] - qd[i, 2]
        data.qacc[lever] = qdd[i, 1] - qdd[i, 2]
        mujoco.mj_inverse(model, data)
        gen = data.qfrc_inverse.copy()
        if wind_k > 0:
            gen -= _mj_wind(mujoco, model, data, wind, wind_k)
        gen[dof[1]] += gen[lever]
        gen[dof[2]] -= gen[lever]
        tau = gen[dof] - friction[i]
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jacSite(model, data, jacp, jacr, face)
        jac = np.vstack([jacp[:, dof], jacr[:, dof]])
        w = -np.linalg.solve(jac.T, tau)
        rot = data.site_xmat[face].reshape(3, 3)
        fl, ml = rot.T @ w[:3], rot.T @ w[3:]
        force[i], moment[i] = w[:3], w[3:]
        loads[i] = (fl[0], fl[1], fl[2], math.hypot(ml[1], ml[2]), ml[0])
    return FlangeWrench(force, moment, loads)
