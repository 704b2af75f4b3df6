"""Closed-loop scenario runs: ship + sensor + estimator + guidance controller + arm plant + event log.

The plant is kinematic: between connections the joints follow the commanded
rates (already limited by the controller to the slew-drive and cylinder
speeds); while the coupler is attached the arm is carried by the flange
(joint angles from the 3D inverse kinematics of the true flange position). If
the flange ever leaves the arm's reach while attached, the run records an
*overstretch*: the failure the alarms exist to prevent. The manual connection
itself (the last ``standoff`` metre, pulled by the operator) is not modelled:
on ``connect`` the coupler is put on the flange.

Everything runs on a simulated clock, so runs are exact and repeatable; the
same controller runs in real time with a wall clock.
"""

from __future__ import annotations

import collections
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from loadarm.arm.slew import forward3d, inverse3d
from loadarm.eventlog import EventLog, RateLimiter
from loadarm.guidance.controller import GuidanceController
from loadarm.guidance.estimator import FlangeEstimator
from loadarm.guidance.modes import MODES, SEVERITY_OF_MODE, Command, OperatorInput, PlantFeedback
from loadarm.guidance.moorings import READING_PERIOD as LINE_LOAD_PERIOD
from loadarm.params.scenario import Scenario, check_run_size
from loadarm.ship.flange import flange_motion
from loadarm.ship.model import moored_ship
from loadarm.sim.limits import ClearanceWatch, first_limit
from loadarm.sim.result import RunResult
from loadarm.sim.sensors import history_readings, sensor_readings
from loadarm.sim.snapshot import state_sample
from loadarm.sim.world import AngleSensors, ArmPlant, ErsValves, ScriptedOperator
from loadarm.vocab import Severity

if TYPE_CHECKING:  # the model is only ever received, never built, here
    from loadarm.arm.model import ArmModel

__all__ = ["run_scenario", "ClosedLoop", "SimulatedPlant", "wall_clock_pacer", "CONTINUOUS_WINDOW",
           "CONTINUOUS_EVENTS"]


def wall_clock_pacer(speedup: float = 1.0) -> Callable[[float], None]:
    """A pacer that makes :func:`run_scenario` keep step with the wall clock.

    Parameters
    ----------
    speedup : float
        Simulated seconds per wall second (1 = real time).

    Returns
    -------
    callable
        ``pace(t)`` sleeps until ``t / speedup`` wall seconds after its first call.
    """
    if not speedup > 0:
        raise ValueError(f"speedup must be > 0, got {speedup!r}")
    start: list[float] = []

    def pace(t: float) -> None:
        if not start:
            start.append(time.monotonic() - t / speedup)
        delay = start[0] + t / speedup - time.monotonic()
        if delay > 0:
            time.sleep(delay)

    return pace


def run_scenario(sc: Scenario, model: ArmModel, *, log: EventLog | None = None, sample_every: float = 1.0,
                 progress: Callable[[float], None] | None = None, plant: str | None = None,
                 pace: Callable[[float], None] | None = None, ship=None) -> RunResult:
    """Run a scenario in closed loop on a simulated clock.

    Parameters
    ----------
    sc : Scenario
        The scenario.
    model : ArmModel
        The arm.
    log : EventLog, optional
        Durable event log; every event is committed as it happens, plus a
        ``sample`` event every ``sample_every`` seconds for replay.
    sample_every : float
        Period of the replay samples in the log, s.
    progress : callable, optional
        Called with the fraction done (0-1) about every 2 % of the run.
    pace : callable, optional
        Called with each cycle's time before the cycle runs; pass
        :func:`wall_clock_pacer` to run in real time (the controller code is
        the same, only the clock changes).
    plant : {'hydraulic', 'kinematic'}, optional
        Arm plant (default the scenario's ``[scenario] plant``): the two
        electro-hydraulic servo drives of :mod:`loadarm.hydraulics` on the
        arm's dynamics (slew kinematic), or ideal rate-following joints.
    ship : ShipModel, optional
        For ``[ship] model = "moored"``: the berth's ship compiled once by the caller (a campaign); default
        compiled from the berth file.

    Returns
    -------
    RunResult
    """
    loop = ClosedLoop(sc, model, log=log, sample_every=sample_every, plant=plant, ship=ship)
    report_every = max(1, loop.n // 50)
    for k in range(loop.n):
        if pace is not None:
            pace(loop.time(k))
        loop.cycle(k)
        if progress is not None and k % report_every == 0:
            progress(k / loop.n)
    if progress is not None:
        progress(1.0)
    return loop.result()


class SimulatedPlant:
    """The scenario's plant in the same process: the ship's flange, the sensor's readings, the arm
    (:class:`ArmPlant`) and the ERS valves, stepped by the controller's commands. ``loadarm plc-sim`` runs the
    same plant behind OPC UA; the controller's side of that link has the same four members
    (:meth:`arrived`, :attr:`q`, :attr:`feedback`, :meth:`step`).

    Parameters
    ----------
    sc : Scenario
    model : ArmModel
    stored : tuple of float
        The stored coupler position the arm starts at, m.
    n : int
        Cycles.
    dt : float
        Cycle, s.
    plant : {'hydraulic', 'kinematic'}
    emit : callable
        ``emit(t, mode, kind, reason, data)``.
    ship : ShipModel, optional
    """

    def __init__(self, sc: Scenario, model: ArmModel, stored, n: int, dt: float, plant: str, emit: Callable, ship=None):
        if ship is None and sc.ship.model == "moored":

            ship = moored_ship(sc)
        self.motion = flange_motion(sc, ship)
        self.readings = sensor_readings(sc, self.motion)
        self.history = history_readings(sc, self.motion)
        self.flange = self.motion.position(np.arange(n) * dt)
        q0 = inverse3d(model.arm, *stored)
        self.arm = ArmPlant(model, np.array([float(q0.phi), float(q0.alpha), float(q0.beta)]), plant, emit,
                            hpu_trip_at=sc.faults.hpu_trip_at)
        self.valves = ErsValves(model.sequence.ers_valve_time, stuck=sc.faults.ers_valve_stuck,
                                delay=sc.faults.ers_valve_delay, false_closed_at=sc.faults.ers_switch_false_closed_at)
        self.sensors = AngleSensors(model, sc.faults)
        # the berth's mooring load monitoring, read once a second (None: not linked, or no lines to read)
        self._mlms = sc.ship.model == "moored" and sc.ship.line_load_monitoring
        self._loads: tuple = (math.nan, None)
        self.feedback = PlantFeedback(angles=self.sensors.second(self.arm.q), line_loads=self.line_loads(0.0))
        self._t = 0.0
        self._ir = 0

    def line_loads(self, now: float) -> tuple | None:
        """The mooring load monitoring's latest reading at ``now`` (each line's load, share of its MBL), or None
        without one."""
        if not self._mlms:
            return None
        reading = self.motion.reading(now, LINE_LOAD_PERIOD)
        if reading != self._loads[0]:
            self._loads = (reading, self.motion.line_loads(now, LINE_LOAD_PERIOD))
        return self._loads[1]

    @property
    def q(self) -> np.ndarray:
        """Joint angles (slew, alpha, beta), rad: the angle encoders (the primary channel; the second is in
        :attr:`feedback`)."""
        return self.sensors.primary(self._t, self.arm.q)

    @property
    def servo_fault(self) -> bool:
        return self.arm.servo_fault

    @property
    def pressures(self) -> tuple[float, float, float, float, float]:
        """Chamber pressures ``pA1, pB1, pA2, pB2`` and the supply pressure, Pa (NaN: the kinematic arm)."""
        servo = self.arm.servo
        if servo is None:
            return (math.nan,) * 5
        y = servo.state.y
        return float(y[4]), float(y[5]), float(y[6]), float(y[7]), float(y[12])

    @property
    def overstretched(self) -> float | None:
        return self.arm.overstretched

    def warm_up(self) -> None:
        """Compile the arm's plant before a real-time run starts its clock (:meth:`ArmPlant.warm_up`)."""
        self.arm.warm_up()

    def arrived(self, now: float):
        """The sensor readings that have arrived by ``now`` since the last call: ``(t_meas, (x, y, z))``."""
        r, out = self.readings, []
        while self._ir < r.t_arrive.size and r.t_arrive[self._ir] <= now:
            z = r.xyz[self._ir]
            out.append((float(r.t_meas[self._ir]), (float(z[0]), float(z[1]), float(z[2]))))
            self._ir += 1
        return out

    def step(self, k: int, now: float, dt: float, cmd) -> tuple[np.ndarray, np.ndarray]:
        """Apply cycle ``k``'s command: the ERS valves, then the arm; returns the true joints and the true
        flange (the sensors' readings of the new pose are the next cycle's :attr:`q` and :attr:`feedback`)."""
        switches = self.valves.step(now, cmd.close_ers_valves)
        q = self.arm.step(now, dt, cmd, self.flange[k])
        self._t = now + dt
        self.feedback = PlantFeedback(ers_switches=switches, angles=self.sensors.second(q),
                                      line_loads=self.line_loads(self._t))
        return q, self.flange[k]

    def first_limit(self, model: ArmModel, sig: dict) -> tuple[float | None, str]:
        """The first time the true flange is past a face after the connection (:func:`first_limit`)."""
        return first_limit(model, sig, self.flange[:sig["t"].size], self.motion)


class ClosedLoop:
    """One closed-loop run of a scenario, a guidance cycle at a time: :func:`run_scenario` drives it on a
    simulated clock, ``loadarm serve`` on the wall clock with the operator's requests
    (:mod:`loadarm.opcua.service`).

    Parameters
    ----------
    sc : Scenario
    model : ArmModel
    log : EventLog, optional
    sample_every : float
        Period of the replay samples in the log, s.
    plant : {'hydraulic', 'kinematic'}, optional
    ship : ShipModel, optional
    scripted : bool
        The scenario's operator acts (default); False: only the inputs given to :meth:`cycle`.
    io : optional
        The plant's inputs and outputs (default the scenario's :class:`SimulatedPlant`).
    continuous : bool
        Run without an end (a real plant through ``io``): the signals are kept for the last
        :data:`CONTINUOUS_WINDOW` s only, cycle ``k`` in slot ``k % n``.

    Attributes
    ----------
    n : int
        Cycles in the scenario's duration (continuous: slots of the signal window).
    dt : float
        Guidance cycle, s.
    ctrl : GuidanceController
    io : SimulatedPlant
        The plant's inputs and outputs (another with the same members: a PLC over OPC UA).
    events : list
        ``(t, mode, kind, reason, data)`` so far.
    estimate : Estimate or None
        The flange estimate of the last cycle.
    """

    def __init__(self, sc: Scenario, model: ArmModel, *, log: EventLog | None = None, sample_every: float = 1.0,
                 plant: str | None = None, ship=None, scripted: bool = True, io=None, continuous: bool = False):
        g = sc.guidance
        if continuous and io is None:
            raise ValueError("continuous needs io (a plant without an end: a PLC); a simulated plant has the "
                             "scenario's duration")
        plant = sc.scenario.plant if plant is None else plant
        if plant not in ("hydraulic", "kinematic"):
            raise ValueError(f"plant must be 'hydraulic' or 'kinematic', got {plant!r}")
        check_run_size(sc)
        self.sc, self.model, self.log = sc, model, log
        self.ctrl = GuidanceController(model, g.compile())
        self.est = FlangeEstimator(noise=sc.sensor.noise, max_age=g.max_estimate_age)
        self.dt = 1.0 / g.rate
        self.continuous = continuous
        self.n = int(math.floor((CONTINUOUS_WINDOW if continuous else sc.scenario.duration) / self.dt)) + 1
        self.events: list = [] if not continuous else collections.deque(maxlen=CONTINUOUS_EVENTS)
        self._limiter = RateLimiter()
        self.io = SimulatedPlant(sc, model, self.ctrl.stored, self.n, self.dt, plant, self.emit, ship) if io is None \
            else io
        history = getattr(self.io, "history", None)
        if history is not None:
            self.ctrl.preload(*history)
        self.operator = ScriptedOperator(sc.operator, self.dt) if scripted else None
        self.rec = _Recorder(self.n, log, sample_every)
        self.clearance = ClearanceWatch(self.emit)
        self.cycle_us = np.full(self.n, np.nan)
        self.estimate = None
        self._ir = 0

    def warm_up(self) -> None:
        """Compile what the cycles call before a real-time run starts its clock (the plant's, if it has one to
        compile: a PLC link has none): a real-time loop is then on time from its first cycle."""
        warm = getattr(self.io, "warm_up", None)
        if warm is not None:
            warm()

    def time(self, k: int) -> float:
        """The time of cycle ``k``, s (a Python float: numpy scalars make every scalar operation slower)."""
        return k * self.dt

    def slot(self, k: int) -> int:
        """Where cycle ``k``'s signals are kept: ``k``, or ``k % n`` in a continuous run."""
        return k % self.n if self.continuous else k

    def emit(self, t, mode, kind, reason, data) -> None:
        """Record an event (rate-limited alike events) and append it to the log."""
        write, suppressed = self._limiter.admit(t, kind, reason, data.get("code", "") if data else "")
        if not write:
            return
        if suppressed:
            reason = f"{reason} (and {suppressed} alike in the last {self._limiter.window:g} s)"
        self.events.append((t, mode, kind, reason, data))
        if self.log is not None:
            self.log.append(t, mode, kind, reason, **data)

    def cycle(self, k: int, live: OperatorInput | None = None) -> Command:
        """Run guidance cycle ``k``: sensor, estimate, controller, valves, plant, record.

        Parameters
        ----------
        k : int
            Cycle, ``0 <= k < n``.
        live : OperatorInput, optional
            The operator's requests this cycle (added to the scripted operator's actions; its jog, if any,
            replaces the script's).

        Returns
        -------
        Command
        """
        now = self.time(k)
        ctrl, io = self.ctrl, self.io
        t0 = time.perf_counter()
        for t_meas, z in io.arrived(now):
            if not self.est.update(t_meas, z):
                self.emit(now, ctrl.state.mode.value, "sensor", "reading rejected as an outlier",
                          {"reading": [float(v) for v in z]})
        e = self.est.estimate(now)
        op = self.operator.inputs(now, ctrl.state.mode, io.servo_fault) if self.operator else OperatorInput()
        if live is not None:
            op = OperatorInput(op.actions + live.actions, live.jog if any(live.jog) else op.jog)
        cmd = ctrl.step(now, io.q, e, op, io.feedback)
        i = self.slot(k)
        self.cycle_us[i] = (time.perf_counter() - t0) * 1e6
        for kind, reason, data in cmd.events:
            self.emit(now, cmd.mode.value, kind, reason, data)
        q, flange = io.step(k, now, self.dt, cmd)
        self.rec.record(i, now, cmd, q, flange, e, self.model.arm, ctrl.state.alarms,
                        bool(io.feedback.ers_valves_closed))
        self.clearance.watch(now, cmd, self._clearance(i, e))
        self.estimate = e
        return cmd

    def _clearance(self, i: int, e) -> float:
        """The coupler's distance from the flange at slot ``i``: from the true flange where the plant knows it (a
        simulation), else from the sensor's estimate while it is healthy (a PLC: found, the watch took the NaN of
        the unknown true flange and raised a false "not clear" alarm after every release), else NaN (unknown)."""
        sig = self.rec.sig
        d = float(sig["distance"][i])
        if math.isnan(d) and e.healthy:
            d = math.dist((float(sig["x"][i]), float(sig["y"][i]), float(sig["z"][i])), e.position)
        return d

    def result(self) -> RunResult:
        """The run's result over the cycles run so far (continuous: over the signal window)."""
        t = self.rec.sig["t"]
        k = int(np.count_nonzero(np.isfinite(t)))
        idx = np.argsort(t)[:k] if self.continuous else slice(0, k)       # NaN (slots not yet run) sort last
        sig = {name: v[idx] for name, v in self.rec.sig.items()}
        al = self.model.alarms
        limit_at, limit_face = self.io.first_limit(self.model, sig)
        return RunResult(self.sc.scenario.name, sig, list(self.events), self.io.overstretched, self.cycle_us[idx],
                         tuple(math.degrees(a) for a in (al.first, al.second, al.release)), limit_at, limit_face)


#: The signals a continuous run keeps (the last hour), s.
CONTINUOUS_WINDOW = 3600.0
#: The events a continuous run keeps in memory (all go to the event log).
CONTINUOUS_EVENTS = 10_000


class _Recorder:
    """The run's signals at every cycle, and a replay sample in the event log every ``sample_every`` s."""

    def __init__(self, n: int, log: EventLog | None, sample_every: float):
        self.sig = {k: np.full(n, np.nan) for k in ("t", "mode", "phi", "alpha", "beta", "x", "y", "z", "fx", "fy",
                                                     "fz", "ex", "ey", "ez", "healthy", "distance", "severity",
                                                     "level", "ttl", "connected")}
        self.log, self.sample_every, self.next_sample = log, sample_every, 0.0

    def record(self, k: int, now: float, cmd, q: np.ndarray, f: np.ndarray, e, arm, alarms=None,
               ers_valves_closed: bool = False) -> None:
        sig = self.sig
        p = forward3d(arm, *q)
        sig["t"][k] = now
        sig["mode"][k] = MODES.index(cmd.mode.value)
        sig["phi"][k], sig["alpha"][k], sig["beta"][k] = q
        sig["x"][k], sig["y"][k], sig["z"][k] = (float(v) for v in p)
        sig["fx"][k], sig["fy"][k], sig["fz"][k] = f
        sig["ex"][k], sig["ey"][k], sig["ez"][k] = e.position
        sig["healthy"][k] = 1.0 if e.healthy else 0.0
        sig["distance"][k] = math.dist((float(p[0]), float(p[1]), float(p[2])), f)
        sig["severity"][k] = int(SEVERITY_OF_MODE.get(cmd.mode, Severity.NORMAL))
        sig["level"][k] = int(cmd.level)
        sig["ttl"][k] = cmd.time_to_limit if math.isfinite(cmd.time_to_limit) else np.nan
        sig["connected"][k] = 1.0 if cmd.connected else 0.0
        if self.log is not None and now >= self.next_sample:
            self.log.append(now, cmd.mode.value, "sample", "state sample",
                            **state_sample(cmd, q, e, sig["distance"][k], ers_valves_closed, alarms or {}))
            self.next_sample += self.sample_every
