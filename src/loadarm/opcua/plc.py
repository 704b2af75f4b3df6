"""The PLC link (issue 14, item 4): a simulated PLC in its own process (``loadarm plc-sim``), and the
controller's side of the link (``loadarm serve --plc``).

The PLC owns the plant: the arm and its valve drivers, the ERS valves and their limit switches, the flange
tracker and the hard-wired E-stop (:class:`PlcSimulator`, the scenario's
:class:`loadarm.sim.loop.SimulatedPlant` on the PLC's own clock). It serves its tags over OPC UA
(:data:`TAGS`, under ``Objects/PLC``; the same security as ``loadarm serve``). The controller writes its
commands and its heartbeat; a command from software is a request:

* **the PLC's watchdog**: when the controller's heartbeat has not changed for :data:`WATCHDOG` seconds (or
  never came), the valve drivers get zero, whatever was written last, and ``WatchdogTripped`` is set;
* **the hard-wired E-stop**: an E-stop request stops the drives (zero rates) until reset by the PLC (the
  request released); it never blocks the release of the coupler or the ERS valves.

The controller's side (:class:`PlcLink`, an asyncua client in its own thread) reads every input at the
guidance rate and writes the latest command after each cycle. The PLC's heartbeat unchanged for
:data:`LINK_TIMEOUT` marks the link dead: its values are then bad (``q`` is NaN, no readings arrive), not
last-known, and the service raises the alarm (and ESD-1 if connected).
"""

from __future__ import annotations

import asyncio
import math
import threading
import time
from dataclasses import dataclass

import numpy as np

from loadarm.errors import ConfigError
from loadarm.files import read_toml
from loadarm.guidance.controller import GuidanceController
from loadarm.guidance.modes import Command, Mode, PlantFeedback
from loadarm.opcua.security import StateDir
from loadarm.opcua.server import APP_URI, SecureServer
from loadarm.sim.loop import SimulatedPlant

__all__ = ["TAGS", "WATCHDOG", "LINK_TIMEOUT", "PLC_APP_URI", "PlcSimulator", "PlcServer", "PlcLink", "TagMap",
           "load_tag_map", "default_tag_map", "tags_markdown"]

#: The PLC's application URI.
PLC_APP_URI = "urn:loadarm:plc-sim"
#: The controller's heartbeat unchanged this long trips the PLC's valve watchdog, s.
WATCHDOG = 0.5
#: The PLC's heartbeat unchanged this long marks the link dead on the controller's side, s.
LINK_TIMEOUT = 0.5
#: Readings kept in ``FlangeBuffer`` (the link reads them all, however many arrived between two reads, up to
#: this many).
BUFFER = 8
#: The PLC server's shortest tick, s (it refreshes 25 tags: faster only starves the PLC's own cycle).
MIN_TICK = 0.005
#: A lost link is tried again this often, s.
RECONNECT = 0.5
#: The PLC's tags: name, type, direction ("in": PLC to controller, "out": controller to PLC), unit, what.
TAGS = (
    ("PlcHeartbeat", int, "in", "", "counts every PLC cycle"),
    ("PlcTime_s", float, "in", "s", "the PLC's clock"),
    ("Phi_rad", float, "in", "rad", "slew encoder"),
    ("Alpha_rad", float, "in", "rad", "inboard arm encoder"),
    ("Beta_rad", float, "in", "rad", "elbow encoder"),
    ("FlangeX_m", float, "in", "m", "the flange tracker's latest reading"),
    ("FlangeY_m", float, "in", "m", "the flange tracker's latest reading"),
    ("FlangeZ_m", float, "in", "m", "the flange tracker's latest reading"),
    ("FlangeTime_s", float, "in", "s", "when that reading was measured (PLC clock)"),
    ("FlangeSeq", int, "in", "", "counts the tracker's readings"),
    ("FlangeBuffer", list, "in", "s, m", f"the last {BUFFER} readings, oldest first: t, x, y, z each"),
    ("ERSValvesClosed", bool, "in", "", "both ERS valves' closed limit switches made"),
    ("EStopActive", bool, "in", "", "the hard-wired emergency stop is active"),
    ("ServoFault", bool, "in", "", "a drive reported a fault"),
    ("WatchdogTripped", bool, "in", "", "the controller's heartbeat stopped: valves at zero"),
    ("LineLoads", list, "in", "1", "the berth's mooring load monitoring, its latest reading: each line's load as a "
                                   "share of its MBL (empty: none; optional in a mapping: unmapped, the predictive "
                                   "alarms never hold a change detector's call)"),
    ("ControllerHeartbeat", int, "out", "", "the controller counts it every cycle"),
    ("Mode", str, "out", "", "the controller's mode"),
    ("RatePhi_rads", float, "out", "rad/s", "slew rate command"),
    ("RateAlpha_rads", float, "out", "rad/s", "inboard arm rate command"),
    ("RateBeta_rads", float, "out", "rad/s", "elbow rate command"),
    ("Connected", bool, "out", "", "the coupler is on the flange"),
    ("Release", bool, "out", "", "ERS-2 release requested"),
    ("CloseERSValves", bool, "out", "", "close the ERS valves"),
    ("EStopRequest", bool, "out", "", "request the emergency stop"),
)
#: The tags a mapping may leave out (a PLC with no link to the berth's mooring load monitoring).
OPTIONAL_TAGS = ("LineLoads",)
_NS = "urn:loadarm:plc-sim:tags"


def _default(name: str, kind):
    if kind is list:                                     # the array tags: the buffer's fixed size, the lines' none
        return {"FlangeBuffer": [0.0] * (4 * BUFFER), "LineLoads": []}[name]
    return {int: 0, float: 0.0, bool: False, str: "STORED"}[kind]


class PlcSimulator:
    """The plant on the PLC's clock, with its watchdog and hard-wired E-stop.

    Parameters
    ----------
    sc : Scenario
    model : ArmModel
    plant : {'hydraulic', 'kinematic'}, optional
        Default the scenario's.
    clock, sleep : callable
        Monotonic seconds and a sleep (injected).
    speedup : float
        PLC seconds per wall second (the watchdog stays in wall seconds).
    ship : ShipModel, optional
        A moored scenario's ship, compiled (:func:`loadarm.sim.spec.load_run`); compiled here if not given.

    Attributes
    ----------
    applied : tuple of float
        The rates the valve drivers got last cycle (zero under the watchdog or the E-stop), rad/s.
    """

    def __init__(self, sc, model, *, plant: str | None = None, clock=time.monotonic, sleep=time.sleep,
                 speedup: float = 1.0, ship=None):
        if not speedup > 0:
            raise ValueError(f"speedup must be > 0, got {speedup!r}")
        self.speedup = speedup

        self.dt = 1.0 / sc.guidance.rate
        self.n = int(math.floor(sc.scenario.duration / self.dt)) + 1
        self.events: list = []
        stored = GuidanceController(model, sc.guidance.compile()).stored
        self.plant = SimulatedPlant(sc, model, stored, self.n, self.dt, plant or sc.scenario.plant, self._emit,
                                    ship=ship)
        self.clock, self.sleep = clock, sleep
        self.outputs = {name: _default(name, kind) for name, kind, d, _, _ in TAGS if d == "out"}
        self.inputs = {name: _default(name, kind) for name, kind, d, _, _ in TAGS if d == "in"}
        self._beat, self._beat_at = None, -math.inf
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.estop = False
        self.applied = (0.0, 0.0, 0.0)

    def _emit(self, t, mode, kind, reason, data):
        self.events.append((t, mode, kind, reason, data))

    def write(self, outputs: dict) -> None:
        """The controller's latest writes (from the OPC UA thread: one dict replaced whole)."""
        self.outputs = dict(outputs)

    def cycle(self, k: int, now: float, wall: float) -> None:
        """One PLC cycle at time ``now`` (wall clock ``wall`` for the watchdog)."""

        out = self.outputs
        if out["ControllerHeartbeat"] != self._beat:
            self._beat, self._beat_at = out["ControllerHeartbeat"], wall
        tripped = wall - self._beat_at > WATCHDOG
        if out["EStopRequest"]:
            self.estop = True
        elif self.estop and not out["EStopRequest"] and out["Mode"] != "ESTOP":
            self.estop = False                  # the request released and the controller reset
        rates = (0.0, 0.0, 0.0) if tripped or self.estop else (
            float(out["RatePhi_rads"]), float(out["RateAlpha_rads"]), float(out["RateBeta_rads"]))
        self.applied = rates
        try:
            mode = Mode(out["Mode"])
        except ValueError:
            mode = Mode.STORED
        cmd = Command(mode=mode, rates=rates, connected=bool(out["Connected"]), esd=False,
                      release=bool(out["Release"]), close_ers_valves=bool(out["CloseERSValves"]))
        q, _ = self.plant.step(k, now, self.dt, cmd)
        self._publish(k, now, q, self.plant.arrived(now), tripped)

    def _publish(self, k: int, now: float, q, new: list, tripped: bool) -> None:
        inputs = dict(self.inputs)
        if new:
            t_meas, z = new[-1]
            buf = list(inputs["FlangeBuffer"])
            for t, (x, y, zz) in new:
                buf = buf[4:] + [t, x, y, zz]
            inputs.update(FlangeX_m=z[0], FlangeY_m=z[1], FlangeZ_m=z[2], FlangeTime_s=t_meas,
                          FlangeSeq=inputs["FlangeSeq"] + len(new), FlangeBuffer=buf)
        inputs.update(PlcHeartbeat=k + 1, PlcTime_s=now, Phi_rad=float(q[0]), Alpha_rad=float(q[1]),
                      Beta_rad=float(q[2]), ERSValvesClosed=bool(self.plant.feedback.ers_valves_closed),
                      EStopActive=self.estop, ServoFault=bool(self.plant.servo_fault), WatchdogTripped=tripped,
                      LineLoads=list(self.plant.feedback.line_loads or ()))
        self.inputs = inputs

    def run(self) -> None:
        """Every cycle of the scenario on the clock, until the end or :meth:`stop`. The clock starts with the
        controller's first heartbeat (the scenario's time 0 is the same on both sides of the link); until then
        the PLC publishes the arm at rest, its watchdog tripped. The arm's plant is compiled first (on time from
        its first cycle)."""
        self.plant.warm_up()
        while self.outputs["ControllerHeartbeat"] == 0 and not self._stop.is_set():
            self._publish(0, 0.0, self.plant.q, [], True)
            self.sleep(self.dt / self.speedup)
        start = self.clock()
        for k in range(self.n):
            if self._stop.is_set():
                return
            now = k * self.dt
            delay = start + now / self.speedup - self.clock()
            if delay > 0:
                self.sleep(delay)
            self.cycle(k, now, self.clock())

    def start(self) -> None:
        self._thread = threading.Thread(target=self.run, name="loadarm-plc", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)


def _variant(kind):
    from asyncua import ua

    return {int: ua.VariantType.Int64, float: ua.VariantType.Double, bool: ua.VariantType.Boolean,
            str: ua.VariantType.String, list: ua.VariantType.Double}[kind]


class PlcServer(SecureServer):
    """The simulated PLC's OPC UA server: the tags under ``Objects/PLC``; the inputs refreshed and the outputs
    read back twice a PLC cycle.

    Parameters
    ----------
    sim : PlcSimulator
    state_dir : path
    endpoint : str
    insecure : bool
    """

    def __init__(self, sim: PlcSimulator, state_dir, endpoint: str, *, insecure: bool = False):
        super().__init__(state_dir, endpoint, PLC_APP_URI, "loadarm simulated PLC", insecure=insecure,
                         period=max(sim.dt / (2 * sim.speedup), MIN_TICK))
        self.sim = sim

    async def _build(self, server) -> dict:
        from asyncua import ua

        ns = await server.register_namespace(_NS)
        plc = await server.nodes.objects.add_object(ua.NodeId("PLC", ns), ua.QualifiedName("PLC", ns))
        nodes = {}
        for name, kind, direction, unit, what in TAGS:
            v = await plc.add_variable(ua.NodeId(f"PLC.{name}", ns), ua.QualifiedName(name, ns),
                                       ua.Variant(_default(name, kind), _variant(kind)))
            await v.write_attribute(ua.AttributeIds.Description,
                                    ua.DataValue(ua.Variant(ua.LocalizedText(f"{what} [{unit}]" if unit else what))))
            if direction == "out":
                await v.set_writable()
            nodes[name] = (v, kind, direction)
        return nodes

    async def _tick(self, nodes: dict) -> None:
        from asyncua import ua

        self.sim.write({name: await v.read_value() for name, (v, _, d) in nodes.items() if d == "out"})
        for name, value in self.sim.inputs.items():
            v, kind, _ = nodes[name]
            await v.write_value(ua.Variant(kind(value), _variant(kind)))


@dataclass(frozen=True)
class TagMap:
    """Where each of :data:`TAGS` is on a PLC: a node id (``nsu=URI;s=...`` or ``ns=N;i=...``) and a scale
    (the PLC's value times ``scale`` is the tag's, in its unit: 0.0174533 for a PLC that gives degrees).

    Attributes
    ----------
    nodes : dict of str to (str, float)
    """

    nodes: dict

    async def resolve(self, client) -> dict:
        """The asyncua nodes, the namespace URIs resolved on this server."""
        from asyncua import ua

        out = {}
        for name, (text, _) in self.nodes.items():
            if text.startswith("nsu="):
                uri, _, rest = text[4:].partition(";")
                text = f"ns={await client.get_namespace_index(uri)};{rest}"
            out[name] = client.get_node(ua.NodeId.from_string(text))
        return out


def tags_markdown() -> str:
    """The PLC tag table of docs/plant-integration.md, from :data:`TAGS` (``make docs`` writes it).

    Returns
    -------
    str
    """
    rows = ["| tag | direction | unit | what |", "|---|---|---|---|"]
    rows += [f"| `{name}`{' (optional)' if name in OPTIONAL_TAGS else ''} | "
             f"{'PLC to controller' if d == 'in' else 'controller to PLC'} | {unit} | {what} |"
             for name, _, d, unit, what in TAGS]
    return "\n".join(rows) + "\n"


def default_tag_map() -> TagMap:
    """The tags where ``loadarm plc-sim`` serves them.

    Returns
    -------
    TagMap
    """
    return TagMap({name: (f"nsu={_NS};s=PLC.{name}", 1.0) for name, *_ in TAGS})


def load_tag_map(path) -> TagMap:
    """Read a mapping file (``--plc-map``)::

        [tags]
        Phi_rad = "nsu=urn:vendor:plc;s=MLA.Slew.Position"
        Alpha_rad = { node = "ns=3;s=MLA.Inboard.Angle", scale = 0.0174533 }   # the PLC gives degrees
        ...

    Every tag of :data:`TAGS` must be mapped; unknown keys are refused.

    Parameters
    ----------
    path : path

    Returns
    -------
    TagMap

    Raises
    ------
    ConfigError
        Naming the file, the key and what was wrong.
    """
    import re

    data = read_toml(path, "PLC mapping")
    src = str(path)
    if set(data) != {"tags"} or not isinstance(data["tags"], dict):
        raise ConfigError(f"{src}: expected one [tags] table, got {', '.join(map(repr, data)) or 'nothing'}")
    names = [t[0] for t in TAGS]
    tags = data["tags"]
    unknown = sorted(set(tags) - set(names))
    if unknown:
        raise ConfigError(f"{src}: unknown tag 'tags.{unknown[0]}'; the tags are {', '.join(names)}")
    missing = [n for n in names if n not in tags and n not in OPTIONAL_TAGS]
    if missing:
        raise ConfigError(f"{src}: tags.{missing[0]} is not mapped (every tag must be: {', '.join(missing)})")
    nodes = {}
    for name in (n for n in names if n in tags):
        v = tags[name]
        node, scale = (v, 1.0) if isinstance(v, str) else (v.get("node"), v.get("scale", 1.0)) \
            if isinstance(v, dict) and set(v) <= {"node", "scale"} else (None, None)
        if not isinstance(node, str) or not re.match(r"^(nsu=[^;]+|ns=\d+);[isgb]=.+$", node):
            raise ConfigError(f"{src}: tags.{name} = {v!r}: a node id like \"nsu=URI;s=NAME\" or \"ns=3;i=1001\", "
                              "or {{ node = ..., scale = ... }}")
        if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not (math.isfinite(scale) and scale != 0):
            raise ConfigError(f"{src}: tags.{name}.scale = {scale!r}: a finite, non-zero number")
        kind = next(t[1] for t in TAGS if t[0] == name)
        if scale != 1.0 and kind is not float:
            raise ConfigError(f"{src}: tags.{name}.scale: only numeric tags scale, {name} is {kind.__name__}")
        nodes[name] = (node, float(scale))
    return TagMap(nodes)


def _cast(value, vt):
    """A value in the Python type of an OPC UA variant type (a PLC's Float, Int16 or Byte for our Double or
    Int64)."""
    from asyncua import ua

    if vt in (ua.VariantType.Float, ua.VariantType.Double):
        return float(value)
    if vt == ua.VariantType.Boolean:
        return bool(value)
    if vt == ua.VariantType.String:
        return str(value)
    return int(value)


class PlcLink:
    """The controller's side of the PLC link: the plant's four members (:meth:`arrived`, :attr:`q`,
    :attr:`feedback`, :meth:`step`) over OPC UA, for :class:`loadarm.sim.loop.ClosedLoop`.

    Parameters
    ----------
    endpoint : str
        The PLC's.
    state_dir : path
        The controller's (its certificate is the client's; the PLC must trust it).
    user, password : str
        The PLC's user for the controller (an engineer: it writes).
    server_certificate : path
        The PLC's certificate (trusted by the operator beforehand).
    period : float
        How often the inputs are read, s.
    tags : TagMap, optional
        Where the tags are on the PLC (default ``loadarm plc-sim``'s).
    clock : callable
    """

    def __init__(self, endpoint: str, state_dir, user: str, password: str, server_certificate, *,
                 period: float = 0.05, tags: TagMap | None = None, clock=time.monotonic):

        self.endpoint, self.state = endpoint, StateDir(state_dir)
        self.user, self.password, self.server_certificate = user, password, server_certificate
        self.period, self.clock = period, clock
        self.tags = tags or default_tag_map()
        self._inputs: dict | None = None
        self._beat, self._beat_at = None, -math.inf
        self._outputs: dict = {name: _default(name, kind) for name, kind, d, _, _ in TAGS if d == "out"}
        self._heartbeat = 0
        self._seq = 0
        self._offset: float | None = None
        self._stop = threading.Event()
        self.connected = threading.Event()
        self.error: BaseException | None = None
        self._thread: threading.Thread | None = None
        self.overstretched = None
        self.servo_fault = False

    # --------------------------------------------------------------- the link's thread
    def start(self, timeout: float = 30.0) -> None:
        """Connect and read the inputs once; raises RuntimeError if the PLC cannot be reached."""

        self.state.ensure(APP_URI)
        self._thread = threading.Thread(target=lambda: asyncio.run(self._main()), name="loadarm-plc-link",
                                        daemon=True)
        self._thread.start()
        if not self.connected.wait(timeout):
            self.stop()
            raise RuntimeError(f"no link to the PLC at {self.endpoint}: {self.error}")

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)

    async def _main(self) -> None:
        while not self._stop.is_set():
            try:
                await self._session()
            except Exception as exc:          # the link is down: link_ok says so from the heartbeat's age
                self.error = exc
            if not self._stop.is_set():
                await asyncio.sleep(RECONNECT)

    async def _session(self) -> None:
        from asyncua import Client, ua
        from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256

        client = Client(self.endpoint, timeout=2)
        client.application_uri = APP_URI
        client.set_user(self.user)
        client.set_password(self.password)
        await client.set_security(SecurityPolicyBasic256Sha256, str(self.state.cert), str(self.state.key),
                                  server_certificate=str(self.server_certificate))
        async with client:
            node = await self.tags.resolve(client)
            scale = {name: s for name, (_, s) in self.tags.nodes.items()}
            ins = [name for name, _, d, _, _ in TAGS if d == "in" and name in node]   # an optional one unmapped
            outs = [(name, kind) for name, kind, d, _, _ in TAGS if d == "out"]
            types = {n: await node[n].read_data_type_as_variant_type() for n, _ in outs}   # the PLC's own types
            while not self._stop.is_set():
                values = await client.read_values([node[n] for n in ins])
                now = self.clock()
                got = {n: v * scale[n] if scale[n] != 1.0 else v for n, v in zip(ins, values)}
                if got["PlcHeartbeat"] != self._beat:
                    self._beat, self._beat_at = got["PlcHeartbeat"], now
                self._inputs = got
                self.connected.set()
                out = self._outputs
                await client.write_values([node[n] for n, _ in outs],
                                          [ua.Variant(_cast(kind(out[n]) / scale[n] if scale[n] != 1.0
                                                            else kind(out[n]), types[n]), types[n])
                                           for n, kind in outs])
                await asyncio.sleep(self.period)

    # --------------------------------------------------------------- the plant's members (the control thread)
    @property
    def link_ok(self) -> bool:
        """The PLC's heartbeat changed within :data:`LINK_TIMEOUT`."""
        return self._inputs is not None and self.clock() - self._beat_at <= LINK_TIMEOUT

    @property
    def q(self) -> np.ndarray:
        """The encoders, rad: the last values read (while the link is dead the controller holds on them to
        run its alarm and ESD-1; what it publishes is marked bad: :attr:`link_ok`)."""
        i = self._inputs
        return np.array([i["Phi_rad"], i["Alpha_rad"], i["Beta_rad"]], dtype=float)

    @property
    def feedback(self):

        i = self._inputs
        # the PLC reads both closed limit switches and votes them itself (it owns the ERS interlock); one signal
        # here, and the angles are its encoders' (no second channel over the link)
        loads = i.get("LineLoads") if i and self.link_ok else None
        return PlantFeedback(ers_switches=(bool(i and self.link_ok and i["ERSValvesClosed"]),),
                             line_loads=tuple(float(v) for v in loads) if loads else None)

    def arrived(self, now: float):
        """The tracker's new readings since the last call, from the PLC's buffer (their times moved onto the
        controller's clock); more than :data:`BUFFER` between two reads: the older ones are lost."""
        i = self._inputs
        if i is None or not self.link_ok:
            return []
        if self._offset is None:
            self._offset = float(i["PlcTime_s"]) - now
        self.servo_fault = bool(i["ServoFault"])
        fresh = min(int(i["FlangeSeq"]) - self._seq, BUFFER)
        if fresh <= 0:
            return []
        self._seq = int(i["FlangeSeq"])
        buf = i["FlangeBuffer"]
        return [(float(buf[j]) - self._offset, (float(buf[j + 1]), float(buf[j + 2]), float(buf[j + 3])))
                for j in range(4 * (BUFFER - fresh), 4 * BUFFER, 4)]

    def step(self, k: int, now: float, dt: float, cmd):
        """Write the cycle's command and heartbeat (the link's thread sends it); returns the encoders and no
        true flange (NaN: the PLC does not know it)."""
        self._heartbeat += 1
        self._outputs = {"ControllerHeartbeat": self._heartbeat, "Mode": cmd.mode.value,
                         "RatePhi_rads": float(cmd.rates[0]), "RateAlpha_rads": float(cmd.rates[1]),
                         "RateBeta_rads": float(cmd.rates[2]), "Connected": bool(cmd.connected),
                         "Release": bool(cmd.release), "CloseERSValves": bool(cmd.close_ers_valves),
                         "EStopRequest": cmd.mode.value == "ESTOP"}
        return self.q, np.full(3, np.nan)

    def _outputs_rates(self) -> tuple[float, float, float]:
        """The rates last written for the PLC (tests)."""
        o = self._outputs
        return (o["RatePhi_rads"], o["RateAlpha_rads"], o["RateBeta_rads"])

    def first_limit(self, model, sig):
        """Unknown over a link (the true flange is the PLC's)."""
        return None, ""
