"""The plant interface (issue 14): users, certificates and the trust list; the OPC UA server of ``loadarm serve``
with real asyncua clients on loopback (an ephemeral port): secure endpoints only, roles enforced per request,
the calling user known to the methods and logged, an operator's jog moving the simulated arm."""

from __future__ import annotations

import asyncio
import os
import stat
import time

import numpy as np
import pytest

from loadarm.errors import ConfigError
from loadarm.opcua.security import Role, StateDir, Users, hash_password, verify_password

SCENARIO = "examples/scenarios/driftoff.toml"


# --------------------------------------------------------------------------- users and certificates

def test_passwords_are_scrypt_hashes_checked_in_constant_time():
    h = hash_password("s3cret")
    assert h.startswith("scrypt$16384$8$1$") and "s3cret" not in h
    assert len(bytes.fromhex(h.split("$")[4])) == 16            # the salt docs/plant-integration.md names
    assert verify_password("s3cret", h) and not verify_password("s3cret ", h) and not verify_password("", h)
    assert not verify_password("s3cret", "md5$abc") and not verify_password("x", "garbage")
    assert hash_password("s3cret") != h                     # salted
    with pytest.raises(ConfigError, match="empty"):
        hash_password("")


def test_the_users_file_round_trips_private_and_refuses_wrong_passwords(tmp_path):
    users = Users(tmp_path / "users.toml")
    users.add("alice", Role.OPERATOR, "pw-a")
    users.add("victor", Role.VIEWER, "pw-v")
    assert stat.S_IMODE(os.stat(tmp_path / "users.toml").st_mode) == 0o600
    again = Users(tmp_path / "users.toml")
    assert again.names() == ["alice", "victor"]
    assert again.authenticate("alice", "pw-a").role == Role.OPERATOR
    assert again.authenticate("alice", "pw-v") is None and again.authenticate("mallory", "pw-a") is None
    assert again.authenticate(None, None) is None


@pytest.mark.parametrize("text, match", [
    ('[users.bob]\nrole = "admin"\npassword = "scrypt$1$1$1$00$00"\n', "unknown role 'admin'"),
    ('[users.bob]\nrole = "viewer"\npassword = "plain"\n', "not an scrypt hash"),
    ('[users.bob]\nrole = "viewer"\n', "exactly the keys role and password"),
    ('[users."a b"]\nrole = "viewer"\npassword = "scrypt$1"\n', "a user name is"),
    ("[other]\n", "only \\[users.NAME\\]"),
    ("users = [", "not valid TOML")])
def test_a_bad_users_file_is_refused_naming_the_file_and_key(tmp_path, text, match):
    f = tmp_path / "users.toml"
    f.write_text(text)
    with pytest.raises(ConfigError, match=match) as exc:
        Users(f)
    assert str(f) in str(exc.value)


def test_the_application_certificate_is_made_once_with_a_private_key(tmp_path):
    from cryptography import x509

    st = StateDir(tmp_path / "state")
    st.ensure("urn:test:server", "localhost")
    assert stat.S_IMODE(st.key.stat().st_mode) == 0o600
    c = x509.load_der_x509_certificate(st.cert.read_bytes())   # what docs/plant-integration.md says of it
    assert c.public_key().key_size == 2048 and c.signature_hash_algorithm.name == "sha256"
    assert (c.not_valid_after_utc - c.not_valid_before_utc).days == 5 * 365
    cert = st.cert.read_bytes()
    st.ensure("urn:test:server", "localhost")               # the second start keeps it
    assert st.cert.read_bytes() == cert
    with pytest.raises(ConfigError, match="another application"):
        st.ensure("urn:other", "localhost")
    os.chmod(st.key, 0o644)
    with pytest.raises(ConfigError, match="readable by others \\(mode 0644\\)"):
        st.ensure("urn:test:server", "localhost")


def test_trust_copies_a_certificate_and_refuses_what_is_not_one(tmp_path):
    st = StateDir(tmp_path / "state")
    cert, _ = _client_cert(tmp_path, "c")
    out = st.trust(cert)
    assert out.parent == st.trusted and out.read_bytes() == cert.read_bytes()
    (tmp_path / "junk.der").write_bytes(b"not a certificate")
    with pytest.raises(ConfigError, match="not an X.509 certificate"):
        st.trust(tmp_path / "junk.der")
    with pytest.raises(ConfigError, match="certificate file not found"):
        st.trust(tmp_path / "missing.der")


def _client_cert(tmp_path, name: str, uri: str = "urn:test:client"):
    from loadarm.opcua.security import client_certificate

    return client_certificate(tmp_path, name, uri)


# --------------------------------------------------------------------------- the server, with real clients

def _free_port() -> int:
    from loadarm.testing.loadtest import free_port

    return free_port()


def _client(served, user=None, password=None, cert=None, key=None):
    from asyncua import Client
    from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256

    async def make():
        c = Client(served["endpoint"], timeout=10)
        c.application_uri = "urn:test:client"
        if user is not None:
            c.set_user(user)
            c.set_password(password)
        await c.set_security(SecurityPolicyBasic256Sha256, str(cert or served["cert"]), str(key or served["key"]),
                             server_certificate=str(served["state"].cert))
        return c

    return make


def _nodes(c):
    """The namespace, the guidance object and a variable getter, once the server has published a cycle."""
    from asyncua import ua

    from loadarm.opcua.server import NAMESPACE

    async def get():
        ns = await c.get_namespace_index(NAMESPACE)
        var = (lambda name: c.get_node(ua.NodeId(f"Guidance.{name}", ns)))
        for _ in range(100):                     # the variables are NaN until the first snapshot is copied
            if await var("Cycle").read_value() > 0:
                break
            await asyncio.sleep(0.05)
        return ns, c.get_node(ua.NodeId("Guidance", ns)), var

    return get()


def test_only_secure_endpoints_are_offered(served):
    from asyncua import Client, ua

    async def main():
        c = Client(served["endpoint"], timeout=10)
        eps = await c.connect_and_get_server_endpoints()
        return {(e.SecurityPolicyUri.split("#")[-1], e.SecurityMode) for e in eps}

    got = asyncio.run(main())
    assert got == {(p, ua.MessageSecurityMode.SignAndEncrypt)
                   for p in ("Basic256Sha256", "Aes128_Sha256_RsaOaep", "Aes256_Sha256_RsaPss")}


@pytest.mark.slow  # make test's 2-minute budget (2-4 s here); CI runs it
def test_an_operator_s_jog_moves_the_arm_and_is_logged_with_the_user(served):
    from asyncua import ua

    async def main():
        c = await _client(served, "alice", "pw-alice")()
        async with c:
            ns, guidance, var = await _nodes(c)
            z0 = await var("CouplerZ_m").read_value()
            for _ in range(8):                  # renewed every 0.2 s: the jog lasts 0.5 s per request
                await guidance.call_method(ua.QualifiedName("Jog", ns), 0.0, 0.0, 0.15)   # the jog speed
                await asyncio.sleep(0.2)
            await guidance.call_method(ua.QualifiedName("Stop", ns))
            await asyncio.sleep(0.3)
            return z0, await var("CouplerZ_m").read_value(), await var("Mode").read_value()

    z0, z1, mode = asyncio.run(main())
    assert mode == "MANUAL" and z1 - z0 > 0.1            # about 1.6 s at 0.15 m/s, less the speed limits
    ops = [e for e in served["service"].loop.events if e[2] == "operator" and e[4].get("user") == "alice"]
    assert {e[4]["action"] for e in ops} >= {"jog", "stop"}


def test_anonymous_may_read_but_not_call_or_write(served):
    from asyncua import ua

    async def main():
        c = await _client(served)()
        async with c:
            ns, guidance, var = await _nodes(c)
            mode = await var("Mode").read_value()
            for name in ("EStop", "ManualESD1"):
                with pytest.raises(ua.uaerrors.BadUserAccessDenied):
                    await guidance.call_method(ua.QualifiedName(name, ns))
            with pytest.raises(ua.uaerrors.BadUserAccessDenied):
                await var("Mode").write_value("ESTOP")
            return mode

    assert asyncio.run(main()) in {"STORED", "MANUAL"}


def test_a_viewer_may_request_esd1_and_nothing_else(served):
    """The one role table (loadarm.vocab.ACTION_TABLE), as the screen serves it: a signed-in viewer (the ship's
    side) may request ESD-1 and no other method; the request reaches the controller under the viewer's name
    (not connected here, so the controller logs it and refuses it). An anonymous session may request nothing
    (test_anonymous_may_read_but_not_call_or_write)."""
    from asyncua import ua

    async def main():
        c = await _client(served, "victor", "pw-victor")()
        async with c:
            ns, guidance, var = await _nodes(c)
            await var("Beta_deg").read_value()
            for name in ("StartApproach", "EStop", "Reset", "AcknowledgeAlarm"):
                with pytest.raises(ua.uaerrors.BadUserAccessDenied):
                    await guidance.call_method(ua.QualifiedName(name, ns))
            with pytest.raises(ua.uaerrors.BadUserAccessDenied):
                await guidance.call_method(ua.QualifiedName("ManualERS", ns), ua.Variant(True))
            await guidance.call_method(ua.QualifiedName("ManualESD1", ns))
            with pytest.raises(ua.uaerrors.BadUserAccessDenied):
                await var("Mode").write_value("ESTOP")
            await asyncio.sleep(0.3)

    asyncio.run(main())
    ops = [e for e in served["service"].loop.events if e[2] == "operator" and e[4].get("user") == "victor"]
    assert [e[4]["action"] for e in ops] == ["esd"]


def test_a_wrong_password_is_refused(served):
    async def main():
        c = await _client(served, "alice", "wrong")()
        await c.connect()

    with pytest.raises(Exception, match="Bad|denied|rejected|closed"):
        asyncio.run(main())


def test_an_untrusted_certificate_is_refused_and_kept_for_the_administrator(served):
    cert, key = _client_cert(served["tmp"], "stranger")

    async def main():
        c = await _client(served, "alice", "pw-alice", cert, key)()
        await c.connect()

    before = set(served["state"].rejected.glob("*.der"))
    with pytest.raises(Exception):
        asyncio.run(main())
    time.sleep(0.2)
    assert len(set(served["state"].rejected.glob("*.der")) - before) == 1


@pytest.mark.slow                      # a server of its own: 4 s (make test SLOW=1, CI)
def test_a_new_state_directory_with_no_trusted_client_starts_and_refuses_every_client(tmp_path, served):
    """Found: the first start of a fresh state directory (nothing in pki/trusted yet: the documented first
    step) failed, asyncua being unable to load an empty trust store. The server now starts and refuses every
    client certificate, keeping it in pki/rejected for the administrator to trust."""
    import shutil

    from loadarm.opcua.server import OpcUaServer

    st = StateDir(tmp_path / "fresh")
    st.users().add("alice", Role.OPERATOR, "pw-alice")
    st.cert.parent.mkdir(parents=True, exist_ok=True)           # the served server's keys: no RSA key made
    shutil.copy(served["state"].cert, st.cert)
    shutil.copy(served["state"].key, st.key)
    os.chmod(st.key, 0o600)
    endpoint = f"opc.tcp://127.0.0.1:{_free_port()}"
    server = OpcUaServer(_FakeService(), st.path, endpoint)
    server.start()
    try:
        cert, key = served["cert"], served["key"]          # trusted by served, not by the fresh one

        async def main():
            c = await _client({"endpoint": endpoint, "state": st, "cert": cert, "key": key}, "alice", "pw-alice")()
            await c.connect()

        with pytest.raises(Exception):
            asyncio.run(main())
        time.sleep(0.2)
        assert len(list(st.rejected.glob("*.der"))) == 1 and not list(st.trusted.iterdir())
    finally:
        server.stop()


def test_the_variables_carry_engineering_units_and_ranges(served):
    async def main():
        c = await _client(served, "victor", "pw-victor")()
        async with c:
            ns, guidance, var = await _nodes(c)
            v = var("Beta_deg")
            eu = await (await v.get_child(["0:EngineeringUnits"])).read_value()
            rng = await (await v.get_child(["0:EURange"])).read_value()
            return eu, rng

    eu, rng = asyncio.run(main())
    assert eu.DisplayName.Text == "deg" and (rng.Low, rng.High) == (0.0, 180.0)
    # OPC 10000-8 5.6.3: the UNECE code's bytes, big-endian (degree of angle: DD); metre is the spec's example
    assert eu.UnitId == int.from_bytes(b"DD", "big")
    from loadarm.opcua.server import unece_unit_id
    assert unece_unit_id("MTR") == 5067858 == int.from_bytes(b"MTR", "big")


def test_the_cylinders_and_face_margins_are_those_of_the_published_pose(served):
    """The cylinder lengths and the margin to each face the server publishes are the actuator and face
    formulas at the pose it publishes (one snapshot: the values agree to round-off)."""
    import math

    from loadarm.arm.actuators import cylinder_lengths
    from loadarm.arm.faces import FACES, face_margins
    from loadarm.params.scenario import load_scenario

    _, model = load_scenario(SCENARIO)

    async def main():
        c = await _client(served, "victor", "pw-victor")()
        async with c:
            ns, guidance, var = await _nodes(c)
            for _ in range(20):                   # a cycle boundary may fall between the reads: read until alike
                names = ["Cycle", "Alpha_deg", "Beta_deg", "CouplerX_m", "CouplerY_m", "CouplerZ_m",
                         "Cylinder1Length_m", "Cylinder2Length_m", *[f"Margin_{f}_deg" for f in FACES], "Cycle"]
                vals = await c.read_values([var(n) for n in names])
                if vals[0] == vals[-1]:
                    return dict(zip(names, vals))
            raise AssertionError("the cycle kept changing")

    v = asyncio.run(main())
    c1, c2 = cylinder_lengths(model.mount, math.radians(v["Alpha_deg"]), math.radians(v["Beta_deg"]))
    assert abs(c1 - v["Cylinder1Length_m"]) < 1e-9 and abs(c2 - v["Cylinder2Length_m"]) < 1e-9
    m = face_margins(model, v["CouplerX_m"], v["CouplerY_m"], v["CouplerZ_m"])
    for i, f in enumerate(FACES):
        assert abs(math.degrees(float(m[..., i])) - v[f"Margin_{f}_deg"]) < 1e-7, f


# --------------------------------------------------------------------------- the commands

def test_user_add_and_trust_from_the_command_line(tmp_path, monkeypatch, capsys):
    import io

    from loadarm.cli import main

    state = tmp_path / "state"
    monkeypatch.setattr("sys.stdin", io.StringIO("pw-bob\n"))
    assert main(["user", "add", "bob", "--role", "engineer", "--password-stdin", "--state-dir", str(state)]) == 0
    assert StateDir(state).users().authenticate("bob", "pw-bob").role == Role.ENGINEER
    assert main(["user", "add", "eve", "--role", "root", "--password-stdin", "--state-dir", str(state)]) == 2
    assert "unknown role 'root'; one of viewer, operator, engineer" in capsys.readouterr().err
    cert, _ = _client_cert(tmp_path, "c")
    assert main(["trust", str(cert), "--state-dir", str(state)]) == 0
    assert len(list(StateDir(state).trusted.glob("*.der"))) == 1
    assert main(["trust", str(tmp_path / "nope.der"), "--state-dir", str(state)]) == 2


@pytest.mark.parametrize("args, match", [
    (["--endpoint", "http://127.0.0.1:4840"], "--endpoint must be opc.tcp://HOST:PORT"),
    (["--endpoint", "opc.tcp://127.0.0.1"], "--endpoint must be opc.tcp://HOST:PORT"),
    (["--speedup", "0"], "--speedup must be a positive number"),
    (["--hmi", "8080"], "--hmi must be HOST:PORT"),

    (["--hmi", "127.0.0.1:99999"], "--hmi port must be in [0, 65535]")])
def test_serve_refuses_a_bad_endpoint_or_speed_in_one_line(tmp_path, capsys, args, match):
    from loadarm.cli import main

    assert main(["serve", "--scenario", SCENARIO, "--state-dir", str(tmp_path / "s"), "--db",
                 str(tmp_path / "e.db"), *args]) == 2
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1


def test_serve_on_a_plc_refuses_a_script_it_has_not_got(tmp_path, capsys):
    from loadarm.cli import main

    assert main(["serve", "--config", "examples/paper.toml", "--plc", "opc.tcp://127.0.0.1:4841", "--plc-cert",
                 "c.der", "--plc-password-file", "pw", "--scripted", "--state-dir", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err
    assert "--scripted needs --scenario" in err and err.count("\n") == 1


def test_the_docs_list_the_whole_address_space():
    """docs/plant-integration.md names every variable, state, method and mode the server builds
    (loadarm.opcua.server.address_space)."""
    from pathlib import Path

    from loadarm.opcua.server import address_space

    doc = Path("docs/plant-integration.md").read_text()
    from loadarm.opcua.plc import tags_markdown
    from loadarm.opcua.server import address_space_markdown

    for table in (*address_space_markdown(), tags_markdown()):    # generated by make docs
        assert table in doc, "regenerate with: make docs"
    space = address_space()
    names = [v[0] for v in space["variables"]] + [s[0] for s in space["states"]] + [m[0] for m in space["methods"]]
    missing = [n for n in names + list(space["modes"]) if f"`{n}`" not in doc]
    assert not missing, f"docs/plant-integration.md lacks {missing}"
    lines = doc.splitlines()
    for name, (_, symbol, _), (lo, hi), _ in space["variables"]:      # each row's unit and range are the server's
        [row] = [ln for ln in lines if ln.startswith("|") and f"`{name}`" in ln and " .. " in ln]
        assert f"| {symbol} | {lo:g} .. {hi:g} |" in row, row
    from loadarm.guidance.modes import ERS_CONFIRM_WINDOW
    from loadarm.opcua.server import PUBLISH_RATE
    from loadarm.opcua.service import JOG_HOLD

    assert f"for {JOG_HOLD:g} s" in doc and f"every {1 / PUBLISH_RATE:g} s" in doc
    assert f"Confirm = true within {ERS_CONFIRM_WINDOW:g} s" in doc
    from loadarm.opcua.plc import LINK_TIMEOUT, RECONNECT, TAGS, WATCHDOG
    from loadarm.vocab import CONDITION_SEVERITY, CONDITION_TEXT

    for tag, sev in CONDITION_SEVERITY.items():
        assert f"| `{tag}` | {sev} | {CONDITION_TEXT[tag]} |" in doc, tag

    missing = [name for name, *_ in TAGS if f"`{name}`" not in doc]
    assert not missing, f"docs/plant-integration.md lacks the PLC tags {missing}"
    assert f"unchanged for {WATCHDOG:g} s (or never come)" in doc
    from loadarm.opcua.plc import BUFFER

    assert f"the last {BUFFER} readings" in doc
    assert f"PLC's heartbeat unchanged for {LINK_TIMEOUT:g} s" in doc and f"every {RECONNECT:g} s" in doc


# --------------------------------------------------------------------------- Part 9 alarms

class _FakeService:
    """A guidance service whose alarm states the test sets (the controller's ISA-18.2 machine is tested on
    its own); it records the requests it gets."""

    def __init__(self):
        from loadarm.sim.snapshot import Snapshot
        from loadarm.vocab import ANNUNCIATED

        self.requests = []
        self.notes = []
        self.alarms = {tag: "normal" for tag in ANNUNCIATED}
        self.seq = 0
        self.mode = "CONNECTED"
        self._make = lambda: Snapshot(seq=self.seq, t=0.1 * self.seq, mode=self.mode, q=(0.0, 1.0, 2.0),
                                      coupler=(1.0, 0.0, 2.0), flange_estimate=(1.0, 0.0, 2.0), estimate_healthy=True,
                                      distance=0.0, level=0, time_to_limit=float("inf"), connected=True, esd=False,
                                      release=False, coupler_open=False, ers_valves_closed=False,
                                      alarms=dict(self.alarms))

    def set(self, tag, state):
        self.alarms[tag] = state
        self.seq += 1

    def set_mode(self, mode):
        self.mode = mode
        self.seq += 1

    def snapshot(self):
        return self._make()

    def request(self, req):
        self.requests.append(req)

    def note(self, kind, reason, data):
        self.notes.append((kind, reason, data))


class _Events:
    """An asyncua subscription handler keeping the events it gets."""

    def __init__(self):
        self.events = []

    def event_notification(self, event):
        self.events.append(event)

    async def wait_for(self, pred, timeout=5.0):
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout:
            hits = [e for e in self.events if pred(e)]
            if hits:
                return hits[-1]
            await asyncio.sleep(0.05)
        raise AssertionError(f"no such event among {len(self.events)}")


@pytest.fixture(scope="module")
def fake_served(served):
    """loadarm's OPC UA server over a :class:`_FakeService` (alarm states and modes the tests set), with the
    users and trust list of ``served``; stopped afterwards."""
    from loadarm.opcua.server import OpcUaServer

    fake = _FakeService()
    endpoint = f"opc.tcp://127.0.0.1:{_free_port()}"
    server = OpcUaServer(fake, served["state"].path, endpoint)
    server.start()
    yield dict(served, endpoint=endpoint, fake=fake)
    server.stop()


def test_alarms_are_part_9_conditions_that_an_operator_acknowledges(fake_served):
    """Each annunciated alarm is an AlarmConditionType condition: its event carries ActiveState, AckedState,
    Retain and the severity; Acknowledge on the condition (an operator) asks the controller to acknowledge
    that alarm, refused for a viewer and for an alarm already acknowledged; ConditionRefresh replays the
    retained conditions."""
    from asyncua import ua

    from loadarm.opcua.server import NAMESPACE
    from loadarm.vocab import CONDITION_SEVERITY

    fake, sv = fake_served["fake"], fake_served
    fake.requests.clear()

    async def main():
        c = await _client(sv, "alice", "pw-alice")()
        v = await _client(sv, "victor", "pw-victor")()
        async with c, v:
            ns = await c.get_namespace_index(NAMESPACE)
            guidance = c.get_node(ua.NodeId("Guidance", ns))
            h = _Events()
            sub = await c.create_subscription(50, h)
            await sub.subscribe_events(guidance, ua.NodeId(ua.ObjectIds.AlarmConditionType))
            fake.set("ESD1", "unacknowledged")
            ev = await h.wait_for(lambda e: e.ConditionName == "ESD1")
            assert getattr(ev, "ActiveState/Id") is True and getattr(ev, "AckedState/Id") is False and ev.Retain
            assert ev.Severity == CONDITION_SEVERITY["ESD1"]
            cond = c.get_node(ua.NodeId("Guidance.Alarms.ESD1", ns))
            ack = ua.NodeId(ua.ObjectIds.AcknowledgeableConditionType_Acknowledge)
            with pytest.raises(ua.uaerrors.BadUserAccessDenied):
                await v.get_node(cond.nodeid).call_method(ack, ev.EventId, ua.LocalizedText("viewer"))
            await cond.call_method(ack, ev.EventId, ua.LocalizedText("seen"))
            assert [(r.action, r.user, r.tag) for r in fake.requests] == [("ack", "alice", "ESD1")]
            assert any(k == "security" and "by victor refused" in r for k, r, _ in fake.notes), fake.notes
            fake.set("ESD1", "acknowledged")
            ev2 = await h.wait_for(lambda e: e.ConditionName == "ESD1" and getattr(e, "AckedState/Id"))
            assert getattr(ev2, "ActiveState/Id") is True and ev2.Retain
            with pytest.raises(ua.uaerrors.BadConditionBranchAlreadyAcked):
                await cond.call_method(ack, ev2.EventId, ua.LocalizedText("again"))
            n = len(h.events)
            await c.nodes.server.call_method(ua.NodeId(ua.ObjectIds.ConditionType_ConditionRefresh),
                                             ua.Variant(sub.subscription_id, ua.VariantType.UInt32))
            replay = await h.wait_for(lambda e: e in h.events[n:] and getattr(e, "ConditionName", None) == "ESD1")
            assert getattr(replay, "AckedState/Id") is True
            fake.set("ESD1", "normal")
            ev3 = await h.wait_for(lambda e: e.ConditionName == "ESD1" and not getattr(e, "ActiveState/Id"))
            assert not ev3.Retain

    asyncio.run(main())


def test_the_guidance_modes_are_a_finite_state_machine_with_transition_events(fake_served):
    """GuidanceMode is an OPC 10000-16 FiniteStateMachineType: CurrentState shows the mode's name, its Id the
    state object and its Number that object's StateNumber; each change of mode emits a TransitionEventType event
    (FromState, ToState, Transition) and writes LastTransition. The Machinery operation mode follows (ALARM1 is
    Processing, MANUAL is Setup)."""
    from asyncua import ua

    from loadarm.opcua.server import NAMESPACE

    fake = fake_served["fake"]
    fake.set_mode("CONNECTED")

    async def main():
        c = await _client(fake_served, "victor", "pw-victor")()
        async with c:
            ns = await c.get_namespace_index(NAMESPACE)
            sm = c.get_node(ua.NodeId("Guidance.GuidanceMode", ns))
            h = _Events()
            sub = await c.create_subscription(50, h)
            await sub.subscribe_events(sm, ua.NodeId(ua.ObjectIds.TransitionEventType))
            current = await sm.get_child(["0:CurrentState"])
            t0 = time.monotonic()
            while (await current.read_value()).Text != "CONNECTED" and time.monotonic() - t0 < 5:
                await asyncio.sleep(0.05)
            fake.set_mode("ALARM1")
            ev = await h.wait_for(lambda e: e.ToState.Text == "ALARM1")
            assert ev.FromState.Text == "CONNECTED" and ev.Transition.Text == "CONNECTED->ALARM1"
            assert getattr(ev, "ToState/Id") == ua.NodeId("Guidance.GuidanceMode.ALARM1", ns)
            assert (await current.read_value()).Text == "ALARM1"
            assert await (await current.get_child(["0:Id"])).read_value() == getattr(ev, "ToState/Id")
            number = await c.get_node(ua.NodeId("Guidance.GuidanceMode.ALARM1", ns)).get_child(["0:StateNumber"])
            assert await (await current.get_child(["0:Number"])).read_value() == await number.read_value()
            assert (await (await sm.get_child(["0:LastTransition"])).read_value()).Text == "CONNECTED->ALARM1"
            fake.set_mode("MANUAL")
            await h.wait_for(lambda e: e.Transition.Text == "ALARM1->MANUAL")
            op = c.get_node(ua.NodeId("MachineryBuildingBlocks.MachineryOperationMode", ns))
            assert (await (await op.get_child(["0:CurrentState"])).read_value()).Text == "Setup"
            assert [e.Transition.Text for e in h.events][-2:] == ["CONNECTED->ALARM1", "ALARM1->MANUAL"]

    asyncio.run(main())


def test_the_controller_acknowledges_one_alarm_or_every_alarm(served):
    """``ack:TAG`` (an OPC UA Acknowledge on one condition) acknowledges that alarm only; ``ack`` every one."""
    from loadarm.arm.alarms import AlarmState
    from loadarm.guidance.controller import GuidanceController
    from loadarm.guidance.estimator import FlangeEstimator
    from loadarm.guidance.modes import OperatorInput
    from loadarm.params.scenario import load_scenario

    sc, model = load_scenario(SCENARIO)
    ctrl = GuidanceController(model, sc.guidance.compile())
    s = ctrl.state
    for tag in ("ESD1", "PRE_ALARM"):
        s.alarms[tag], s.last_active[tag] = AlarmState.UNACKED, 0.0
    s.quiet = False
    est = FlangeEstimator(noise=sc.sensor.noise, max_age=sc.guidance.max_estimate_age)
    q = (0.0, 1.0, 2.0)
    ctrl.step(0.1, q, est.estimate(0.1), OperatorInput(("ack:ESD1",)))
    assert s.alarms["ESD1"] == AlarmState.ACKED and s.alarms["PRE_ALARM"] == AlarmState.UNACKED
    ctrl.step(0.2, q, est.estimate(0.2), OperatorInput(("ack",)))
    assert s.alarms["PRE_ALARM"] == AlarmState.ACKED


# --------------------------------------------------------------------------- a run without an end

def test_a_continuous_loop_keeps_the_last_window_of_its_signals(monkeypatch):
    """``serve --plc`` without a scenario runs on: its ClosedLoop keeps the signals of the last
    CONTINUOUS_WINDOW in a ring (cycle k in slot k % n) and the events in a bounded deque. Over the same plant
    it gives, bit for bit, the last window of the run that keeps everything."""
    from loadarm.params.scenario import load_scenario
    from loadarm.sim import loop as run

    sc, model = load_scenario(SCENARIO)
    monkeypatch.setattr(run, "CONTINUOUS_WINDOW", 2.0)
    with pytest.raises(ValueError, match="continuous needs io"):
        run.ClosedLoop(sc, model, continuous=True)
    ref = run.ClosedLoop(sc, model, plant="kinematic")
    ring = run.ClosedLoop(sc, model, plant="kinematic", io=object(), continuous=True)
    ring.io = run.SimulatedPlant(sc, model, ring.ctrl.stored, ref.n, ref.dt, "kinematic", ring.emit)
    cycles = int(25.0 / ref.dt)                         # past the approach's start at 1 s, and 12 windows
    for k in range(cycles):
        ref.cycle(k)
        ring.cycle(k)
    assert ring.n == int(2.0 / ring.dt) + 1 and ring.slot(cycles) == cycles % ring.n
    a, b = ref.result(), ring.result()
    assert b.signals["t"].size == ring.n and np.all(np.diff(b.signals["t"]) > 0)
    for name, v in b.signals.items():
        np.testing.assert_array_equal(v, a.signals[name][cycles - ring.n:], err_msg=name)
    assert b.events == a.events and len(a.events) > 0
    assert {"APPROACH"} <= {e[1] for e in b.events}


# --------------------------------------------------------------------------- load

def test_a_stall_of_the_machine_shows_as_one_run_of_late_cycles():
    """The service keeps its late cycles with how late each was: a stall of 110 ms within cycle 10 (clock and
    sleep injected) makes cycles 11-14 late by 90, 70, 50 and 30 ms, caught up back to back; cycle 15 is due
    10 ms after the stall's end and is not late (a cycle is late from one period behind)."""
    from loadarm.opcua.service import GuidanceService
    from loadarm.params.scenario import load_scenario
    from loadarm.sim.loop import ClosedLoop

    sc, model = load_scenario(SCENARIO)
    now = [0.0]
    service = GuidanceService(ClosedLoop(sc, model, plant="kinematic"), clock=lambda: now[0],
                              sleep=lambda s: now.__setitem__(0, now[0] + s))
    cycle = service.loop.cycle

    def stalling(k, live=None):
        if k == 10:
            now[0] += 0.110
        if k == 25:
            service.stop()
        return cycle(k, live)

    service.loop.cycle = stalling
    service.run()
    assert service.late == 4 and [k for k, _ in service.late_tail] == [11, 12, 13, 14]
    np.testing.assert_allclose([lag for _, lag in service.late_tail], [0.09, 0.07, 0.05, 0.03], atol=1e-9)


def test_freeze_heap_collects_the_garbage_then_freezes_the_rest():
    """A real-time process freezes its heap once built: the garbage is collected first (a reference cycle made
    before is gone, not frozen forever), and the rest is in the permanent generation."""
    import gc
    import weakref

    from loadarm.opcua.service import freeze_heap

    class Node:
        pass

    a = Node()
    a.me = a
    gone = weakref.ref(a)
    del a
    try:
        n = freeze_heap()
        assert gone() is None and n > 1000 and 0 < gc.get_freeze_count() <= n    # a frozen object freed leaves
    finally:
        gc.unfreeze()


@pytest.mark.slow
@pytest.mark.realtime
def test_twenty_clients_at_10_hz_do_not_make_the_guidance_cycle_late(tmp_path):
    """20 sessions in another process, each subscribed to every variable at 10 Hz for 10 s, while the
    controller runs the drift-off at 50 Hz: its cycles' p99 stays below the 20 ms period, at most one cycle in
    200 starts a period late, and the clients get their notifications (at least a variable's worth per client
    per publish). Found: in CI, with the suite's other worker on the second of two cores beside the clients'
    process, one cycle in 650 started late, and on the next run 60 in 778; alone (make bench) none did. So it is
    marked realtime: the Makefile runs it after the rest, on its own. Found again, alone in CI: 13 cycles in 732
    late in one run, none in the two runs right after it; this shared VM stalls now and then. So a second
    measurement is taken when the first misses: a slow server misses both. Found again in CI: both missed (17 in
    802, 19 in 726). Reproduced here with a busy loop on the other core (3 runs in 4 missed): each time one run of
    12-19 consecutive cycles, the first 240-350 ms late, right after a full pass of the garbage collector over the
    whole heap (250-390 ms) in the OPC UA server's thread. Mended by :func:`loadarm.opcua.service.freeze_heap`
    (``serve`` and ``plc-sim`` call it before their loops): with it, 7 runs in 8 had no late cycle under the same
    load. The message gives each measurement's late cycles (cycle, ms late) so that a miss says stall or drift."""
    from loadarm.testing.loadtest import measure_load

    tries = []
    for attempt in range(2):
        r = measure_load(tmp_path / f"try{attempt}", SCENARIO, seconds=10.0, clients=20)
        ok = (r["late"] <= len(r["cycle_us_during"]) / 200,
              r["notifications"] >= r["clients"] * 10 * r["seconds"] * 0.9,
              np.percentile(r["cycle_us_during"], 99) < 20_000)
        tries.append((r["late"], len(r["cycle_us_during"]), r["notifications"],
                      float(np.percentile(r["cycle_us_during"], 99)),
                      [(k, round(lag * 1e3)) for k, lag in r["late_at"][:20]]))
        if all(ok):
            break
    assert all(ok), f"(late cycles, cycles, notifications, p99 us, late at) of each measurement: {tries}"


def test_the_prediction_and_the_alarm_rule_are_served(served):
    """Issue 30 item 5: OPC UA serves the prediction's horizon and its time to limit with its interval, the rule
    behind the alarm stage, and a call for ESD-1 the prediction holds (how long, how much longer at most). The
    served drift-off has no track before the run: no prediction (horizon 0, times -1), no stage (rule empty), no
    call held (-1); the values of a prediction and of a held call are the snapshot's (unit)."""
    from types import SimpleNamespace

    from loadarm.opcua.server import _held_values, _prediction_values

    async def main():
        c = await _client(served, "victor", "pw-victor")()
        async with c:
            ns, guidance, var = await _nodes(c)
            names = ["PredictionHorizon_s", "PredictedTimeToLimit_s", "PredictedTimeToLimitMean_s", "AlarmRule",
                     "Moorings", "HeldCall_s", "HoldLeft_s"]
            return dict(zip(names, await c.read_values([var(n) for n in names])))

    v = asyncio.run(main())
    assert v == {"PredictionHorizon_s": 0.0, "PredictedTimeToLimit_s": -1.0, "PredictedTimeToLimitMean_s": -1.0,
                 "AlarmRule": "", "Moorings": "none", "HeldCall_s": -1.0, "HoldLeft_s": -1.0}, v   # no lines, no call
    assert _prediction_values({"claimed": 120.0, "ttl": [42.0, None]}) == {
        "PredictedTimeToLimit_s": 42.0, "PredictedTimeToLimitMean_s": -1.0, "PredictionHorizon_s": 120.0}
    snap = SimpleNamespace(connected=True, held=(208.04, 210.64), t=209.54)
    assert _held_values(snap) == pytest.approx({"HeldCall_s": 1.5, "HoldLeft_s": 1.1})
    assert _held_values(SimpleNamespace(connected=False, held=(208.04, 210.64), t=209.54))["HeldCall_s"] == -1.0
