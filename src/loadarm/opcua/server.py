"""The OPC UA server of ``loadarm serve`` (asyncua), secure by default.

* **Endpoints**: Basic256Sha256, Aes128_Sha256_RsaOaep and Aes256_Sha256_RsaPss, SignAndEncrypt only; the
  unsecured endpoint exists only with ``insecure=True`` (a lab).
* **Certificates**: the application's own from the state directory (:class:`loadarm.opcua.security.StateDir`,
  made on first start); a client's must be in ``pki/trusted/`` (read at start: a certificate copied there is
  trusted after a restart); a refused one is copied to ``pki/rejected/`` for the administrator.
* **Users**: user name and password against the users file (scrypt), or anonymous. The roles
  (:class:`loadarm.vocab.Role`) are enforced per request by :class:`RoleRuleset` and per method by the one
  action table (:data:`loadarm.vocab.ACTION_TABLE`, which the screen serves too): anonymous sessions browse,
  read and subscribe; a signed-in viewer may also request ESD-1 (ManualESD1); operators call every method;
  engineers also write. Everything else is refused with ``BadUserAccessDenied``.
* **Who called**: asyncua passes no user to a method callback. The ruleset sees every request with its
  session's user first, in the connection's own task, which then awaits the call: the user is put in a
  context variable there (:data:`CURRENT_USER`), which the callback reads in the same task.

The server runs its asyncio loop in its own thread; it reads the guidance service's latest snapshot at
:data:`PUBLISH_RATE` and writes the variables, and a method call only queues a request
(:meth:`loadarm.opcua.service.GuidanceService.request`): nothing blocks the event loop, nothing of OPC UA runs
in the control loop.
"""

from __future__ import annotations

import asyncio
import contextvars
import logging
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass

from loadarm import __version__
from loadarm.arm.alarms import AlarmState
from loadarm.guidance.modes import ERS_CONFIRM_WINDOW, Mode
from loadarm.opcua.security import LoginLimiter, Role, StateDir, User, is_user_name, thumbprint
from loadarm.opcua.service import JOG_HOLD, Request, parse_jog
from loadarm.sim.snapshot import held_times
from loadarm.vocab import (ANNUNCIATED, CONDITION_SEVERITY, FACE_LABELS, Severity, action_role, condition_severity,
                           condition_text)
from loadarm.vocab import METHODS as _METHODS

__all__ = ["APP_URI", "NAMESPACE", "PUBLISH_RATE", "CURRENT_USER", "RoleRuleset", "SecureServer",
           "SnapshotServer", "OpcUaServer", "address_space", "address_space_markdown", "unece_unit_id",
           "conditions", "acknowledge_method"]

#: The application URI (in the certificate's subject alternative names).
APP_URI = "urn:loadarm:guidance"
#: loadarm's namespace.
NAMESPACE = "urn:loadarm:guidance:model"
#: OPC 40001-1 (Machinery) and OPC 10000-100 (DI): the browse names of their building blocks are used in
#: their namespaces (the companion types themselves are not loaded: see docs/plant-integration.md).
MACHINERY_NS = "http://opcfoundation.org/UA/Machinery/"
DI_NS = "http://opcfoundation.org/UA/DI/"
#: Variables are refreshed from the controller's snapshot this often, Hz.
PUBLISH_RATE = 10.0
#: The user of the request being processed (set by :class:`RoleRuleset`, read by the method callbacks).
CURRENT_USER: contextvars.ContextVar = contextvars.ContextVar("loadarm_opcua_user", default=None)

_log = logging.getLogger(__name__)


def _policies():
    from asyncua import ua

    return [ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt,
            ua.SecurityPolicyType.Aes128Sha256RsaOaep_SignAndEncrypt,
            ua.SecurityPolicyType.Aes256Sha256RsaPss_SignAndEncrypt]


def _request_ids():
    """Request types each kind of session may send: an anonymous one (key None) views only; a signed-in viewer
    may also call, and each method then checks the action's own role (:data:`loadarm.vocab.ACTION_TABLE`: a
    viewer's one request is ESD-1); an engineer may also write and read history."""
    from asyncua import ua
    from asyncua.crypto.permission_rules import USER_TYPES

    # a subscription stays with the session that made it (TransferSubscriptions would move one past its caps)
    every = {ua.NodeId(i) for i in USER_TYPES} - {ua.NodeId(ua.ObjectIds.TransferSubscriptionsRequest_Encoding_DefaultBinary)}
    write = {ua.NodeId(ua.ObjectIds.WriteRequest_Encoding_DefaultBinary)}
    call = {ua.NodeId(ua.ObjectIds.CallRequest_Encoding_DefaultBinary)}
    history = {ua.NodeId(ua.ObjectIds.HistoryReadRequest_Encoding_DefaultBinary)}
    view = every - write - call
    return {None: view, Role.VIEWER: view | call, Role.OPERATOR: view | call,
            Role.ENGINEER: view | call | write | history}


class RoleRuleset:
    """asyncua permission ruleset by loadarm role; anonymous sessions view only. Records the request's user
    in :data:`CURRENT_USER` (see the module's notes)."""

    def __init__(self):
        self._allowed = _request_ids()

    def check_validity(self, user, action_type_id, body) -> bool:
        """Whether ``user`` may send this request type (asyncua calls it before every request of a session)."""
        CURRENT_USER.set(user)
        role = _role(user)
        return action_type_id in self._allowed[role]


def _role(user) -> Role | None:
    """The signed-in user's role; None for an anonymous session."""
    who = getattr(user, "loadarm", None)
    return who.role if who is not None else None


def _user_manager(users, limiter: LoginLimiter, security_event, anonymous: bool = False):
    """asyncua's user manager over the users file, with the screen's login limit (per user name and per client
    certificate; found: 40 wrong passwords went through in 6.8 s). Each refusal is a security event
    (``security_event(code, reason, data)``)."""
    from asyncua.crypto.permission_rules import User as UaUser
    from asyncua.crypto.permission_rules import UserRole

    @dataclass
    class _User(UaUser):
        loadarm: User | None = None

    class _Manager:
        def get_user(self, iserver, username=None, password=None, certificate=None):
            if username is None:                 # anonymous (``certificate`` is the secure channel's; certificate
                if not anonymous:                # identity tokens are not offered); found: a user-name token with
                    return None                  # no name was taken as anonymous though anonymous was off
                return _User(role=UserRole.Anonymous, name=None, loadarm=None)
            client = _client_name(certificate)
            name = str(username) if is_user_name(username) else "<not a user name>"    # bounded before any use
            wait, ticket = limiter.begin(name, client)
            if wait > 0:
                security_event("security.login_limited", "OPC UA login refused: too many failed logins",
                               {"user": name, "client": client})
                return None
            who = users.authenticate(username, password) if is_user_name(username) else None
            if who is None:
                security_event("security.login_refused", "OPC UA login refused: wrong user name or password",
                               {"user": name, "client": client})
                return None
            limiter.succeeded(who.name, client, ticket)
            return _User(role=UserRole.User, name=who.name, loadarm=who)

    return _Manager()


def _client_name(certificate) -> str:
    """A client by its certificate's thumbprint (an OPC UA client has no other identity the server can trust)."""
    if certificate is None:
        return "a client without a certificate"
    try:
        from cryptography import x509

        cert = certificate if not isinstance(certificate, bytes) else x509.load_der_x509_certificate(certificate)
        return f"certificate {thumbprint(cert)[:16]}"
    except (ValueError, TypeError, AttributeError):
        return "a client with an unreadable certificate"


def _validator(state: StateDir):
    """The client-certificate check: trusted (in ``pki/trusted``), in its validity period, a client's; a
    refused certificate is copied to ``pki/rejected``. An empty trust list refuses every client (found: asyncua
    cannot load an empty store, and the first start of a new state directory failed)."""
    from asyncua import ua
    from asyncua.crypto.truststore import TrustStore
    from asyncua.crypto.validator import CertificateValidator
    from asyncua.crypto.validator import CertificateValidatorOptions as O

    state.trusted.mkdir(parents=True, exist_ok=True)
    empty = not any(p.is_file() for p in state.trusted.iterdir())
    store = TrustStore([state.trusted], [])
    check = CertificateValidator(O.TRUSTED_VALIDATION | O.PEER_CLIENT, store)

    async def validate(cert, app_description):
        try:
            if empty:
                raise ua.UaStatusCodeError(ua.StatusCodes.BadCertificateUntrusted)
            await check(cert, app_description)
        except Exception:
            from cryptography.hazmat.primitives import serialization

            state.rejected.mkdir(parents=True, exist_ok=True)
            (state.rejected / f"{thumbprint(cert)}.der").write_bytes(cert.public_bytes(serialization.Encoding.DER))
            _log.warning("OPC UA client certificate refused (copied to %s)", state.rejected)
            raise

    return store, validate, empty


# --------------------------------------------------------------------------- the address space

#: Variables of the guidance object: browse name, unit (UNECE code, symbol, description), range, what it is.
VARIABLES = (
    ("Slew_deg", ("DD", "deg", "degree"), (-180.0, 180.0), "slew angle"),
    ("Alpha_deg", ("DD", "deg", "degree"), (-180.0, 180.0), "inboard arm angle"),
    ("Beta_deg", ("DD", "deg", "degree"), (0.0, 180.0), "elbow angle (customer's beta)"),
    ("CouplerX_m", ("MTR", "m", "metre"), (-100.0, 100.0), "coupler position, installation frame"),
    ("CouplerY_m", ("MTR", "m", "metre"), (-100.0, 100.0), "coupler position, installation frame"),
    ("CouplerZ_m", ("MTR", "m", "metre"), (-100.0, 100.0), "coupler position, installation frame"),
    ("FlangeX_m", ("MTR", "m", "metre"), (-100.0, 100.0), "flange estimate (Kalman filter)"),
    ("FlangeY_m", ("MTR", "m", "metre"), (-100.0, 100.0), "flange estimate (Kalman filter)"),
    ("FlangeZ_m", ("MTR", "m", "metre"), (-100.0, 100.0), "flange estimate (Kalman filter)"),
    ("DistanceToFlange_m", ("MTR", "m", "metre"), (0.0, 200.0), "coupler to flange"),
    ("TimeToLimit_s", ("SEC", "s", "second"), (0.0, 3600.0), "design-drift time to the nearest face (-1: none)"),
    ("PredictedTimeToLimit_s", ("SEC", "s", "second"), (0.0, 3600.0),
     "the flange prediction's time to the nearest face by its calibrated bound (-1: none within its horizon)"),
    ("PredictedTimeToLimitMean_s", ("SEC", "s", "second"), (0.0, 3600.0),
     "the flange prediction's time to the nearest face by its mean track (-1: none within its horizon)"),
    ("PredictionHorizon_s", ("SEC", "s", "second"), (0.0, 3600.0),
     "how far ahead the flange prediction is claimed (0: no prediction)"),
    ("HeldCall_s", ("SEC", "s", "second"), (0.0, 3600.0),
     "how long the prediction has held the measured drift's call for ESD-1 (-1: no call held)"),
    ("HoldLeft_s", ("SEC", "s", "second"), (0.0, 3600.0),
     "how much longer that call may be held at most (-1: no call held)"),
    ("CycleTime_us", ("B98", "us", "microsecond"), (0.0, 1e6), "guidance cycle computing time"),
    ("Cylinder1Length_m", ("MTR", "m", "metre"), (0.0, 10.0), "cylinder 1 pin-to-pin length"),
    ("Cylinder2Length_m", ("MTR", "m", "metre"), (0.0, 10.0), "cylinder 2 pin-to-pin length"),
) + tuple((f"Margin_{face}_deg", ("DD", "deg", "degree"), (-180.0, 180.0), f"margin to the face, in its joint's angle (NaN: out of reach): {text}")
          for face, text in FACE_LABELS.items())
#: Boolean and integer state variables.
STATES = (("EstimateHealthy", bool), ("Connected", bool), ("ESDActive", bool), ("ReleaseRequested", bool),
          ("CouplerOpen", bool), ("ERSValvesClosed", bool), ("AlarmStage", int), ("AlarmStageText", str),
          ("Mode", str), ("Cycle", int), ("LateCycles", int), ("PlantLinkOK", bool), ("AlarmRule", str),
          ("Moorings", str), ("PredictionUnused", str))
#: Methods: browse name, request action, input arguments, what it does (the one action table,
#: :data:`loadarm.vocab.ACTION_TABLE`, with the service's jog hold and the controller's ERS window filled in).
METHODS = tuple((name, action, args, what.format(jog_hold=JOG_HOLD, ers_window=ERS_CONFIRM_WINDOW))
                for name, action, args, what in _METHODS)
#: OPC 40001-1 MachineryOperationMode and MachineryItemState of each guidance mode (jog is Setup).
OPERATION_MODE = {"STORED": "None", "MANUAL": "Setup", "ESTOP": "None"}
ITEM_STATE = {"STORED": "NotExecuting", "HOLD": "NotExecuting", "ESTOP": "OutOfService", "MANUAL": "Executing"}


def address_space() -> dict:
    """The address space as data: what :class:`OpcUaServer` builds and ``docs/plant-integration.md`` lists.

    Returns
    -------
    dict
        ``variables``, ``states``, ``methods``, ``modes``.
    """

    return {"variables": VARIABLES, "states": STATES, "methods": METHODS, "modes": tuple(m.value for m in Mode)}


def address_space_markdown() -> tuple[str, str]:
    """The tables of docs/plant-integration.md's address space, from the server's own declarations
    (``make docs`` writes them; a test holds the page to them).

    Returns
    -------
    variables, methods : str
        Markdown tables.
    """
    var = ["| variable | unit | range | what |", "|---|---|---|---|"]
    var += [f"| `{name}` | {sym} | {lo:g} .. {hi:g} | {what} |" for name, (_, sym, _), (lo, hi), what in VARIABLES]
    meth = ["| method | arguments | does |", "|---|---|---|"]
    meth += [f"| `{name}` | {', '.join(args)} | {what} |" for name, _, args, what in METHODS]
    return "\n".join(var) + "\n", "\n".join(meth) + "\n"


#: Limits every loadarm server sets (asyncua's own defaults admit a thousand connections and any rate; found: 60
#: anonymous sessions were held open, and 15 clients sampling every variable at 10 ms made 285 cycles late).
#: TCP connections at once (each a session at most).
MAX_CONNECTIONS = 32
#: A connection that has not activated a session after this long is closed, s.
ACTIVATION_WAIT = 10.0
#: Subscriptions on the server, and per session.
MAX_SUBSCRIPTIONS, MAX_SUBSCRIPTIONS_PER_SESSION = 64, 4
#: Monitored items per session (the guidance object has about 70 variables and states).
MAX_ITEMS_PER_SESSION = 200
#: The fastest publishing and sampling a client gets, ms (the server publishes every 1 / PUBLISH_RATE s: asking
#: for more only costs the guidance's host).
MIN_PUBLISHING_MS = MIN_SAMPLING_MS = 100.0


def _apply_limits(server) -> None:
    """This server's limits (:data:`MAX_CONNECTIONS` ...): set on its own instances, so two servers in one process
    keep their own. A faster interval is revised to the least (as OPC UA lets a server); a subscription or an item
    past its cap is refused with OPC UA's status (BadTooManySubscriptions, BadTooManyMonitoredItems)."""
    from asyncua import ua
    from asyncua.common.utils import ServiceError

    iserver = server.iserver
    iserver.max_connections = MAX_CONNECTIONS
    iserver.max_subscriptions = MAX_SUBSCRIPTIONS
    iserver.max_pending_activation_seconds = ACTIVATION_WAIT
    subs = iserver.subscription_service
    create_subscription, create_items = subs.create_subscription, subs.create_monitored_items

    async def limited_subscription(params, callback, session_id, request_callback=None):
        if sum(s.session_id == session_id for s in subs.subscriptions.values()) >= MAX_SUBSCRIPTIONS_PER_SESSION:
            raise ServiceError(ua.StatusCodes.BadTooManySubscriptions)
        asked = params.RequestedPublishingInterval                # NaN compares false: it gets the least too
        params.RequestedPublishingInterval = asked if asked >= MIN_PUBLISHING_MS else MIN_PUBLISHING_MS
        return await create_subscription(params, callback, session_id, request_callback)

    async def limited_items(params):
        sub = subs.subscriptions.get(params.SubscriptionId)
        if sub is None:
            return await create_items(params)
        held = sum(len(s.monitored_item_srv._monitored_items) for s in subs.subscriptions.values()
                   if s.session_id == sub.session_id)
        room = max(0, MAX_ITEMS_PER_SESSION - held)
        items, refused = list(params.ItemsToCreate[:room]), len(params.ItemsToCreate) - room
        for item in items:
            p = item.RequestedParameters
            asked = p.SamplingInterval                  # -1: the subscription's interval, already limited
            p.SamplingInterval = asked if asked >= MIN_SAMPLING_MS or asked == -1 else MIN_SAMPLING_MS
        params.ItemsToCreate = items
        results = await create_items(params) if items else []
        return results + [ua.MonitoredItemCreateResult(StatusCode=ua.StatusCode(
            ua.StatusCodes.BadTooManyMonitoredItems)) for _ in range(max(0, refused))]

    subs.create_subscription, subs.create_monitored_items = limited_subscription, limited_items


class SecureServer:
    """An asyncua server in its own thread, secure as the module says: the state directory's certificate, the
    trust list, the users and :class:`RoleRuleset`. A subclass builds its address space (:meth:`_build`) and
    is ticked every ``period`` seconds on the server's loop (:meth:`_tick`).

    Parameters
    ----------
    state_dir : path
    endpoint : str
        ``opc.tcp://HOST:PORT``.
    app_uri : str
        The application URI (its certificate's).
    title : str
        Server name.
    insecure : bool
        Also offer the unsecured endpoint (a lab only).
    period : float
        Tick, s.
    anonymous : bool
        Also accept anonymous sessions (read-only). Off by default: every session is a user of the users file.
    """

    def __init__(self, state_dir, endpoint: str, app_uri: str, title: str, *, insecure: bool = False,
                 period: float = 1.0 / PUBLISH_RATE, anonymous: bool = False):
        self.state, self.endpoint, self.app_uri, self.title = StateDir(state_dir), endpoint, app_uri, title
        self.insecure, self.period, self.anonymous = insecure, period, anonymous
        self.ready = threading.Event()
        self.error: BaseException | None = None
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stopping: asyncio.Event | None = None
        #: Failed logins per user name and per client certificate (:class:`loadarm.opcua.security.LoginLimiter`).
        self.limiter = LoginLimiter()

    def _security_event(self, code: str, reason: str, data: dict) -> None:
        """A refused login or request: logged (Python's logging here; the guidance server's event log too)."""
        _log.warning("%s", reason)

    def start(self, timeout: float = 30.0) -> None:
        """Start the server's thread and wait until it listens.

        Raises
        ------
        RuntimeError
            It did not start (the cause chained).
        """
        from urllib.parse import urlparse

        host = urlparse(self.endpoint).hostname or "localhost"
        self.state.ensure(self.app_uri, host)
        self._thread = threading.Thread(target=self._run, name=f"opcua-{self.app_uri}", daemon=True)
        self._thread.start()
        if not self.ready.wait(timeout) or self.error is not None:
            self.stop()
            raise RuntimeError(f"the OPC UA server on {self.endpoint} did not start: {self.error}") from self.error

    def stop(self, timeout: float = 10.0) -> None:
        """Stop the server and wait for its thread."""
        if self._loop is not None and self._stopping is not None:
            try:
                self._loop.call_soon_threadsafe(self._stopping.set)
            except RuntimeError:                  # its loop has ended already (it failed to start)
                pass
        if self._thread is not None:
            self._thread.join(timeout)

    def _run(self) -> None:
        try:
            asyncio.run(self._main())
        except BaseException as exc:
            self.error = exc
            self.ready.set()

    async def _main(self) -> None:
        from asyncua import Server, ua

        self._loop = asyncio.get_running_loop()
        self._stopping = asyncio.Event()
        server = Server(user_manager=_user_manager(self.state.users(), self.limiter, self._security_event,
                                                   self.anonymous))
        server.iserver.bind_condition_methods = True
        await server.init()
        server.set_endpoint(self.endpoint)
        server.set_server_name(self.title)
        await server.set_application_uri(self.app_uri)
        await server.load_certificate(str(self.state.cert))
        await server.load_private_key(str(self.state.key))
        policies = _policies() + ([ua.SecurityPolicyType.NoSecurity] if self.insecure else [])
        server.set_security_policy(policies, permission_ruleset=RoleRuleset())
        server.set_identity_tokens([ua.AnonymousIdentityToken, ua.UserNameIdentityToken] if self.anonymous
                                   else [ua.UserNameIdentityToken])
        _apply_limits(server)
        store, validate, empty = _validator(self.state)
        if not empty:
            await store.load()
        server.set_certificate_validator(validate)
        nodes = await self._build(server)
        async with server:
            self.ready.set()
            while not self._stopping.is_set():
                try:
                    await self._tick(nodes)
                except Exception as exc:              # the server stays up; the error is reported once
                    if self.error is None:
                        _log.exception("OPC UA server tick failed")
                        self.error = exc
                try:
                    await asyncio.wait_for(self._stopping.wait(), self.period)
                except asyncio.TimeoutError:
                    pass

    async def _build(self, server) -> dict:
        raise NotImplementedError

    async def _tick(self, nodes: dict) -> None:
        raise NotImplementedError


class SnapshotServer(SecureServer):
    """A :class:`SecureServer` over a service's snapshots (the guidance's, the bank's): each tick publishes the
    latest snapshot when it is new (:meth:`_publish`, the subclass's); the address space starts from
    :meth:`_machines`.

    Parameters
    ----------
    service
        Its :meth:`snapshot` (each with its ``seq``) and :meth:`note`.
    name : str
        The installation's name (the nameplate's model).
    state_dir, endpoint, app_uri, title
        As :class:`SecureServer`.
    **options
        :class:`SecureServer`'s keywords (``insecure``, ``period``, ``anonymous``).
    """

    def __init__(self, service, name: str, state_dir, endpoint: str, app_uri: str, title: str, **options):
        super().__init__(state_dir, endpoint, app_uri, title, **options)
        self.service, self.name = service, name
        self._last = -1

    async def _tick(self, nodes: dict) -> None:
        snap = self.service.snapshot()
        if snap is not None and snap.seq != self._last:
            self._last = snap.seq
            await self._publish(nodes, snap)

    async def _publish(self, nodes: dict, snap) -> None:
        raise NotImplementedError

    @staticmethod
    async def _machines(server) -> tuple:
        """loadarm's, Machinery's and DI's namespaces registered, and the Machines folder (OPC 40001-1) the
        machines go in: ``(ns, mns, dns, machines)``."""
        from asyncua import ua

        ns = await server.register_namespace(NAMESPACE)
        mns = await server.register_namespace(MACHINERY_NS)
        dns = await server.register_namespace(DI_NS)
        machines = await server.nodes.objects.add_folder(ua.NodeId("Machines", ns), ua.QualifiedName("Machines", mns))
        return ns, mns, dns, machines


class OpcUaServer(SnapshotServer):
    """The OPC UA server of a :class:`loadarm.opcua.service.GuidanceService`, in its own thread.

    Parameters
    ----------
    service : GuidanceService
    state_dir : path
    endpoint : str
        ``opc.tcp://HOST:PORT`` (default loopback).
    insecure : bool
        Also offer the unsecured endpoint (a lab only).
    name : str
        Installation name (the nameplate's model).
    anonymous : bool
        Also accept anonymous, read-only sessions (off by default).
    """

    def __init__(self, service, state_dir, endpoint: str = "opc.tcp://127.0.0.1:4840", *, insecure: bool = False,
                 name: str = "loadarm", anonymous: bool = False):
        super().__init__(service, name, state_dir, endpoint, APP_URI, f"loadarm guidance ({name})",
                         insecure=insecure, anonymous=anonymous)

    def _security_event(self, code: str, reason: str, data: dict) -> None:
        """A refused login: in the event log, with the controller's events (and Python's logging)."""
        super()._security_event(code, reason, data)
        self.service.note("security", reason, {"code": code, **data})

    async def _build(self, server) -> dict:
        from asyncua import ua

        ns, _, dns, machines = await self._machines(server)
        arm = await machines.add_object(ua.NodeId("LoadingArm", ns), ua.QualifiedName("LoadingArm", ns))
        ident = await arm.add_object(ua.NodeId("Identification", ns), ua.QualifiedName("Identification", dns))
        for key, value in (("Manufacturer", "loadarm (open source)"), ("Model", self.name),
                           ("ProductInstanceUri", f"{APP_URI}:{self.name}"), ("SoftwareRevision", __version__),
                           ("SerialNumber", self.name)):
            await ident.add_property(ua.NodeId(f"Identification.{key}", ns), ua.QualifiedName(key, dns),
                                     ua.LocalizedText(value) if key == "Manufacturer" else value)
        blocks = await arm.add_object(ua.NodeId("MachineryBuildingBlocks", ns),
                                      ua.QualifiedName("MachineryBuildingBlocks", dns))
        nodes: dict = {}
        machines_sm = {"MachineryItemState": ("NotAvailable", "OutOfService", "Executing", "NotExecuting"),
                       "MachineryOperationMode": ("None", "Maintenance", "Setup", "Processing")}
        for bname, states in machines_sm.items():
            nodes[bname] = await _state_machine(server, blocks, ns, bname, states)
        guidance = await arm.add_object(ua.NodeId("Guidance", ns), ua.QualifiedName("Guidance", ns))
        nodes["GuidanceMode"] = await _state_machine(server, guidance, ns, "GuidanceMode", address_space()["modes"])
        for bname, (code, symbol, text), (lo, hi), what in VARIABLES:
            v = await guidance.add_variable(ua.NodeId(f"Guidance.{bname}", ns), ua.QualifiedName(bname, ns), math.nan,
                                            varianttype=ua.VariantType.Double)
            await v.write_attribute(ua.AttributeIds.Description, ua.DataValue(ua.Variant(ua.LocalizedText(what))))
            await v.add_property(ua.NodeId(f"Guidance.{bname}.EngineeringUnits", ns),
                                 ua.QualifiedName("EngineeringUnits", 0),
                                 ua.EUInformation(NamespaceUri="http://www.opcfoundation.org/UA/units/un/cefact",
                                                  UnitId=unece_unit_id(code), DisplayName=ua.LocalizedText(symbol),
                                                  Description=ua.LocalizedText(text)))
            await v.add_property(ua.NodeId(f"Guidance.{bname}.EURange", ns), ua.QualifiedName("EURange", 0),
                                 ua.Range(Low=lo, High=hi))
            nodes[bname] = v
        for bname, kind in STATES:
            vt = {bool: ua.VariantType.Boolean, int: ua.VariantType.Int64, str: ua.VariantType.String}[kind]
            nodes[bname] = await guidance.add_variable(ua.NodeId(f"Guidance.{bname}", ns),
                                                       ua.QualifiedName(bname, ns), kind(), varianttype=vt)
        for tag in self._alarm_tags():
            nodes[f"Alarm.{tag}"] = await guidance.add_variable(ua.NodeId(f"Guidance.Alarm.{tag}", ns),
                                                                ua.QualifiedName(f"Alarm_{tag}", ns), "normal")
        nodes["conditions"] = await conditions(server, guidance, ns, self._alarm_tags())
        server.iserver.isession.add_method_callback(
            ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge), self._acknowledge(nodes["conditions"]))
        for bname, action, args, what in METHODS:
            inputs = [_argument(a) for a in args]
            await guidance.add_method(ua.NodeId(f"Guidance.{bname}", ns), ua.QualifiedName(bname, ns),
                                      self._callback(action, args), inputs, [])
        return nodes

    @staticmethod
    def _alarm_tags():
        return ANNUNCIATED

    def _acknowledge(self, conditions: dict):
        """The Acknowledge method of the conditions: an operator's request to acknowledge that one alarm (the
        controller's ISA-18.2 state machine does it; the condition follows at the next snapshot)."""
        service = self.service
        return acknowledge_method(conditions, lambda user, tag, _: service.request(Request("ack", user, tag=tag)),
                                  service.note)

    def _callback(self, action: str, args: tuple):
        from asyncua import ua

        service = self.service

        async def method(parent, *values):
            user = CURRENT_USER.get()
            who = getattr(user, "loadarm", None)
            vals = [v.Value for v in values]
            asked = "ers_confirm" if action == "ers" and vals and vals[0] is True else action
            if who is None or who.role < action_role(asked):      # the one role table (loadarm.vocab)
                return ua.StatusCode(ua.StatusCodes.BadUserAccessDenied)
            try:
                req = _method_request(action, who.name, values, service.jog_speed)
            except (TypeError, ValueError) as exc:
                service.note("security", f"OPC UA {action} of {who.name} refused: {exc}",
                             {"code": "security.command_refused", "user": who.name, "action": action})
                return ua.StatusCode(ua.StatusCodes.BadInvalidArgument)
            service.request(req)
            return []

        return method

    async def _publish(self, nodes: dict, snap) -> None:
        from asyncua import ua

        def num(x):
            return float(x) if math.isfinite(x) else -1.0

        values = {"Slew_deg": math.degrees(snap.q[0]), "Alpha_deg": math.degrees(snap.q[1]),
                  "Beta_deg": math.degrees(snap.q[2]), "CouplerX_m": snap.coupler[0], "CouplerY_m": snap.coupler[1],
                  "CouplerZ_m": snap.coupler[2], "FlangeX_m": snap.flange_estimate[0],
                  "FlangeY_m": snap.flange_estimate[1], "FlangeZ_m": snap.flange_estimate[2],
                  "DistanceToFlange_m": snap.distance, "TimeToLimit_s": num(snap.time_to_limit),
                  **_prediction_values(snap.prediction), **_held_values(snap),
                  "CycleTime_us": snap.cycle_us, "Cylinder1Length_m": snap.cylinders[0],
                  "Cylinder2Length_m": snap.cylinders[1],
                  **{f"Margin_{f}_deg": math.degrees(v) for f, v in snap.margins.items()}}
        bad = ua.StatusCode(ua.StatusCodes.BadCommunicationError)
        for k, v in values.items():
            if not snap.plant_ok and k not in ("CycleTime_us",):      # a dead PLC link: bad, not last-known
                await nodes[k].write_value(ua.DataValue(ua.Variant(float(v), ua.VariantType.Double),
                                                        StatusCode=bad))
            else:
                await nodes[k].write_value(ua.Variant(float(v), ua.VariantType.Double))
        for k, v in (("EstimateHealthy", snap.estimate_healthy), ("Connected", snap.connected),
                     ("ESDActive", snap.esd), ("ReleaseRequested", snap.release), ("CouplerOpen", snap.coupler_open),
                     ("ERSValvesClosed", snap.ers_valves_closed), ("PlantLinkOK", snap.plant_ok)):
            await nodes[k].write_value(ua.Variant(bool(v), ua.VariantType.Boolean))
        for k, v in (("AlarmStage", snap.level), ("Cycle", snap.seq), ("LateCycles", snap.late)):
            await nodes[k].write_value(ua.Variant(int(v), ua.VariantType.Int64))
        await nodes["AlarmStageText"].write_value(Severity(snap.level).label)
        await nodes["Mode"].write_value(snap.mode)
        await nodes["AlarmRule"].write_value(snap.rule)
        await nodes["Moorings"].write_value(snap.moorings)
        await nodes["PredictionUnused"].write_value(str((snap.prediction or {}).get("unused", "")))
        for key, state in (("GuidanceMode", snap.mode), ("MachineryOperationMode",
                                                       OPERATION_MODE.get(snap.mode, "Processing")),
                           ("MachineryItemState", ITEM_STATE.get(snap.mode, "Executing"))):
            await nodes[key].set(state)
        for tag, state in snap.alarms.items():
            if f"Alarm.{tag}" in nodes:
                await nodes[f"Alarm.{tag}"].write_value(state)
            cond = nodes["conditions"].get(tag)
            if cond is not None and cond.state != state:
                await cond.report(state)


def _prediction_values(p: dict | None) -> dict:
    """The prediction's variables from a snapshot's (:func:`loadarm.sim.snapshot.prediction_sample`): -1 where
    there is no time within the claim, a horizon of 0 for no prediction."""
    if p is None:
        return {"PredictedTimeToLimit_s": -1.0, "PredictedTimeToLimitMean_s": -1.0, "PredictionHorizon_s": 0.0}
    bound, mean = p["ttl"]
    return {"PredictedTimeToLimit_s": -1.0 if bound is None else float(bound),
            "PredictedTimeToLimitMean_s": -1.0 if mean is None else float(mean),
            "PredictionHorizon_s": float(p["claimed"])}


def _held_values(snap) -> dict:
    """The held call's variables from a snapshot (:attr:`loadarm.sim.snapshot.Snapshot.held`): -1 when none."""
    held, left = held_times(snap) or (-1.0, -1.0)
    return {"HeldCall_s": held, "HoldLeft_s": left}


def _method_request(action: str, user: str, values, jog_speed: float) -> Request:
    """The request of a method call, its arguments taken strictly: Jog three Doubles (finite, of speed at most the
    jog speed), ManualERS one Boolean, the others none (found: Int64 and Boolean jogs, and 1e300, were taken).

    Raises
    ------
    ValueError
        Naming the arguments expected and those sent.
    """
    types = [v.VariantType.name for v in values]
    if action == "jog":
        if types != ["Double"] * 3:
            raise ValueError(f"Jog takes three Double arguments (vx, vy, vz, m/s), got {', '.join(types) or 'none'}")
        return Request("jog", user, parse_jog([v.Value for v in values], jog_speed))
    if action == "ers":
        if types not in ([], ["Boolean"]):
            raise ValueError(f"ManualERS takes one Boolean argument (Confirm), got {', '.join(types)}")
        confirm = bool(values) and values[0].Value is True
        return Request("ers_confirm" if confirm else "ers", user)
    if values:
        raise ValueError(f"{action} takes no argument, got {', '.join(types)}")
    return Request(action, user)


class _StateMachine:
    """An OPC UA finite state machine (OPC 10000-16): an instance of its own subtype of FiniteStateMachineType,
    one state object per name (InitialStateType first, then StateType, numbered from 1). Each change writes
    CurrentState (its name, Id and Number) and LastTransition, and the machine emits a TransitionEventType event
    (FromState, ToState, Transition "FROM->TO") that a client subscribes to on the machine's node."""

    def __init__(self, node, current, current_id, current_number, last, states: dict, numbers: dict, evgen):
        self.node, self.current, self.current_id, self.current_number = node, current, current_id, current_number
        self.last, self.states, self.numbers, self.evgen = last, states, numbers, evgen
        self.state: str | None = None

    async def set(self, state: str) -> None:
        """Enter ``state`` (nothing if it is the current one)."""
        from asyncua import ua

        if state == self.state:
            return
        before, self.state = self.state, state
        await self.current.write_value(ua.LocalizedText(state, "en"))
        await self.current_id.write_value(ua.Variant(self.states[state].nodeid, ua.VariantType.NodeId))
        await self.current_number.write_value(ua.Variant(self.numbers[state], ua.VariantType.UInt32))
        if before is None:                       # the first state is where the machine starts: no transition
            return
        name = f"{before}->{state}"
        await self.last.write_value(ua.LocalizedText(name, "en"))
        ev = self.evgen.event
        ev.Message = ua.LocalizedText(f"{(await self.node.read_browse_name()).Name}: {name}")
        ev.Severity = 100
        ev.Transition = ua.LocalizedText(name, "en")
        ev.FromState = ua.LocalizedText(before, "en")
        setattr(ev, "FromState/Id", ua.Variant(self.states[before].nodeid, ua.VariantType.NodeId))
        ev.ToState = ua.LocalizedText(state, "en")
        setattr(ev, "ToState/Id", ua.Variant(self.states[state].nodeid, ua.VariantType.NodeId))
        await self.evgen.trigger()


async def _state_machine(server, parent, ns: int, name: str, states) -> _StateMachine:
    """Build the :class:`_StateMachine` ``parent/name`` with ``states``."""
    from asyncua import ua

    base = f"{parent.nodeid.Identifier}.{name}"
    fsm_type = await server.get_node(ua.ObjectIds.FiniteStateMachineType).add_object_type(
        ua.NodeId(f"{name}StateMachineType", ns), ua.QualifiedName(f"{name}StateMachineType", ns))
    sm = await parent.add_object(ua.NodeId(base, ns), ua.QualifiedName(name, ns), objecttype=fsm_type.nodeid)
    await sm.set_event_notifier([ua.EventNotifier.SubscribeToEvents])
    current = await sm.get_child(["0:CurrentState"])
    current_id = await current.get_child(["0:Id"])
    current_number = await current.add_property(ua.NodeId(f"{base}.CurrentState.Number", ns),
                                                ua.QualifiedName("Number", 0), ua.Variant(0, ua.VariantType.UInt32))
    last = await sm.get_child(["0:LastTransition"])
    nodes, numbers = {}, {}
    for i, st in enumerate(states):
        node = await sm.add_object(ua.NodeId(f"{base}.{st}", ns), ua.QualifiedName(st, ns),
                                   objecttype=ua.NodeId(ua.ObjectIds.InitialStateType if i == 0
                                                        else ua.ObjectIds.StateType))
        number = await node.get_child(["0:StateNumber"])
        await number.write_value(ua.Variant(i + 1, ua.VariantType.UInt32))
        nodes[st], numbers[st] = node, i + 1
    evgen = await server.get_event_generator(ua.ObjectIds.TransitionEventType, sm)
    return _StateMachine(sm, current, current_id, current_number, last, nodes, numbers, evgen)


class _Condition:
    """One annunciated alarm as a Part 9 AlarmConditionType condition: its node and event generator; the
    controller's ISA-18.2 state (:class:`loadarm.arm.alarms.AlarmState`) reported as ActiveState and AckedState
    (asyncua has no condition state machine of its own: the controller's is the one)."""

    def __init__(self, tag: str, node, evgen, prefix: str = ""):
        self.tag, self.node, self.evgen, self.prefix = tag, node, evgen, prefix
        self.state, self.suppressed = "normal", False

    @property
    def event_id(self) -> bytes | None:
        """The EventId of its latest event (None before the first)."""
        return _value(getattr(self.evgen.event, "EventId", None))

    async def report(self, state: str, suppressed: bool = False) -> None:
        """One event of the alarm's state: its ISA-18.2 ``state`` and whether it is suppressed by design (a bank
        arm's lower stage while a higher one is active: ISA-18.2's state-based suppression, Part 9's
        SuppressedState; still acknowledgeable)."""
        from asyncua import ua

        st = AlarmState(state)
        active = st in (AlarmState.UNACKED, AlarmState.ACKED)
        acked = st in (AlarmState.ACKED, AlarmState.NORMAL)
        ev = self.evgen.event
        ev.NodeId = self.node.nodeid
        ev.ConditionName = self.tag
        ev.Severity = condition_severity(self.tag)
        ev.Message = ua.LocalizedText(f"{self.prefix}{condition_text(self.tag)} ({st.value})")
        ev.Retain = st != AlarmState.NORMAL
        setattr(ev, "EnabledState/Id", True)
        ev.EnabledState = ua.LocalizedText("Enabled")
        setattr(ev, "ActiveState/Id", active)
        ev.ActiveState = ua.LocalizedText("Active" if active else "Inactive")
        setattr(ev, "AckedState/Id", acked)
        ev.AckedState = ua.LocalizedText("Acknowledged" if acked else "Unacknowledged")
        setattr(ev, "SuppressedState/Id", suppressed)
        ev.SuppressedState = ua.LocalizedText("Suppressed" if suppressed else "Unsuppressed")
        ev.SuppressedOrShelved = suppressed
        self.state, self.suppressed = state, suppressed
        await self.evgen.trigger()


async def conditions(server, parent, ns: int, tags, prefix: str = "", source: str | None = None) -> dict:
    """A condition object (AlarmConditionType) and its event generator per annunciated alarm, under
    ``parent/Alarms``; the parent emits their events.

    Parameters
    ----------
    server : asyncua.Server
    parent : asyncua.Node
        The object the conditions belong to (their events' SourceNode).
    ns : int
        loadarm's namespace index.
    tags : sequence of str
        The alarms' tags (:mod:`loadarm.vocab`'s conditions).
    prefix : str
        Starts each event's message (a bank's arm: ``"L1: "``).
    source : str, optional
        The events' SourceName (a bank's arm; default the parent's browse name).

    Returns
    -------
    dict
        Each tag's :class:`_Condition`.
    """
    from asyncua import ua

    folder = await parent.add_folder(ua.NodeId(f"{parent.nodeid.Identifier}.Alarms", ns), ua.QualifiedName("Alarms", ns))
    out = {}
    for tag in tags:
        node = await folder.add_object(ua.NodeId(f"{parent.nodeid.Identifier}.Alarms.{tag}", ns),
                                       ua.QualifiedName(tag, ns), objecttype=ua.NodeId(ua.ObjectIds.AlarmConditionType))
        evgen = await server.get_event_generator(ua.ObjectIds.AlarmConditionType, parent)
        evgen.event.SourceNode = parent.nodeid
        if source is not None:
            evgen.event.SourceName = source
        out[tag] = _Condition(tag, node, evgen, prefix)
    return out


def acknowledge_method(conditions: dict, ask: Callable[[str, object], bool | None],
                       note: Callable[[str, str, dict], None] | None = None):
    """The callback of AcknowledgeableConditionType's Acknowledge, bound for every condition of a server: an
    operator's request to acknowledge one alarm, refused to a lesser role (the one role table, :mod:`loadarm.vocab`;
    noted as a security event), for a node that is not one of ``conditions``, for an alarm not waiting for its
    acknowledgement or whose acknowledgement is already asked, and for an EventId that is not the condition's
    latest event (Part 9: an operator acknowledges the occurrence they saw, not one that rose since). The state
    machine that owns the alarm acknowledges it; its condition follows at the next published state.

    Parameters
    ----------
    conditions : dict
        Each condition's key (what ``ask`` is given) to its :class:`_Condition`.
    ask : callable
        ``ask(user, key, comment)``: the request, from the server's thread (it must not block); False if that
        acknowledgement is already waiting. ``comment`` is the Acknowledge's comment's text ("" if none).
    note : callable, optional
        The service's ``note(kind, reason, data)``, for refusals.

    Returns
    -------
    coroutine function
    """
    from asyncua import ua

    by_node = {c.node.nodeid: key for key, c in conditions.items()}

    async def acknowledge(parent, *values):
        user = CURRENT_USER.get()
        who = getattr(user, "loadarm", None)
        key = by_node.get(parent)
        if who is None or who.role < action_role("ack"):
            if note is not None:
                name = "an anonymous session" if who is None else who.name
                note("security", f"OPC UA acknowledge of {key} by {name} refused: needs the operator role",
                     {"code": "security.command_refused", "user": getattr(who, "name", ""), "action": "ack"})
            return ua.StatusCode(ua.StatusCodes.BadUserAccessDenied)
        if key is None:
            return ua.StatusCode(ua.StatusCodes.BadNodeIdInvalid)
        cond = conditions[key]
        if cond.state in ("normal", "acknowledged"):
            return ua.StatusCode(ua.StatusCodes.BadConditionBranchAlreadyAcked)
        if not values or _value(values[0]) != cond.event_id:
            return ua.StatusCode(ua.StatusCodes.BadEventIdUnknown)
        comment = _value(values[1]) if len(values) > 1 else None
        if ask(who.name, key, getattr(comment, "Text", None) or "") is False:
            return ua.StatusCode(ua.StatusCodes.BadConditionBranchAlreadyAcked)
        return []

    return acknowledge


def _value(v):
    """A method argument's value (a Variant's, or as given)."""
    return getattr(v, "Value", v)


def unece_unit_id(code: str) -> int:
    """OPC UA's UnitId of a UNECE common code (its characters packed, OPC 10000-8 5.6.3).

    Parameters
    ----------
    code : str
        The UNECE Recommendation 20 common code, e.g. ``"MTR"`` (metre).

    Returns
    -------
    int
        The code's characters packed, first character highest (``"MTR"``: 5067858).
    """
    out = 0
    for c in code:
        out = (out << 8) | ord(c)
    return out


def _argument(name: str):
    from asyncua import ua

    arg = ua.Argument()
    arg.Name = name
    arg.DataType = ua.NodeId(ua.ObjectIds.Boolean if name == "Confirm" else ua.ObjectIds.Double)
    arg.ValueRank = -1
    arg.Description = ua.LocalizedText("m/s" if name != "Confirm" else "true confirms an armed release")
    return arg
