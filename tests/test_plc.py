"""The PLC link (issue 14, item 4): the simulated PLC's watchdog and E-stop on their own, then ``loadarm plc-sim``
in its own process on loopback with the controller's link: encoders and commands across the link, a jog that
moves the PLC's arm, and the PLC killed mid-run (the controller's reaction time, the alarm, bad values)."""

from __future__ import annotations

import contextlib
import subprocess
import sys
import time

import numpy as np
import pytest

from loadarm.opcua.plc import LINK_TIMEOUT, PLC_APP_URI, WATCHDOG, PlcSimulator
from loadarm.opcua.security import Role, StateDir
from loadarm.params.scenario import load_scenario

SCENARIO = "examples/scenarios/driftoff.toml"


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(SCENARIO)


def _outputs(sim, **kw):
    out = dict(sim.outputs)
    out.update(kw)
    return out


def test_the_plc_watchdog_zeroes_the_valves_when_the_heartbeat_stops(scenario):
    """Rate commands move the PLC's arm while the controller's heartbeat counts; with the heartbeat frozen,
    WatchdogTripped is set once WATCHDOG seconds have passed (not before), the valve drivers get zero whatever
    was written last, and the (kinematic) arm stands still; a new heartbeat moves it again. (The hydraulic arm
    settles over some seconds after its valves close: the servo's own dynamics, not the watchdog's.)"""
    sc, model = scenario
    sim = PlcSimulator(sc, model, plant="kinematic")
    dt = sim.dt
    wall = 0.0
    for k in range(10):
        sim.write(_outputs(sim, ControllerHeartbeat=k + 1, RateBeta_rads=0.01, Mode="MANUAL"))
        sim.cycle(k, k * dt, wall)
        wall += dt
    assert not sim.inputs["WatchdogTripped"]
    frozen_at, k = wall - dt, 10
    trace = []
    while wall - frozen_at < WATCHDOG + 3.0:
        sim.cycle(k, k * dt, wall)                       # the same heartbeat, the same rate command
        trace.append((wall - frozen_at, sim.inputs["WatchdogTripped"], sim.inputs["Beta_rad"]))
        wall += dt
        k += 1
    assert all(tr == (t > WATCHDOG) for t, tr, _ in trace)
    assert sim.applied == (0.0, 0.0, 0.0)
    late = [b for t, _, b in trace if t > WATCHDOG + dt]
    assert max(np.abs(np.diff(late))) == 0.0 and late[0] > trace[0][2]
    rest = late[-1]
    sim.write(_outputs(sim, ControllerHeartbeat=999))
    for j in range(5):
        sim.cycle(k + j, (k + j) * dt, wall + j * dt)
    assert not sim.inputs["WatchdogTripped"] and sim.inputs["Beta_rad"] > rest + 1e-6


def test_an_estop_request_stops_the_drives_until_released_and_reset(scenario):
    sc, model = scenario
    sim = PlcSimulator(sc, model, plant="kinematic")
    dt = sim.dt
    sim.write(_outputs(sim, ControllerHeartbeat=1, RateBeta_rads=0.01, EStopRequest=True, Mode="ESTOP"))
    sim.cycle(0, 0.0, 0.0)
    b0 = sim.inputs["Beta_rad"]
    for k in range(1, 10):
        sim.write(_outputs(sim, ControllerHeartbeat=k + 1))
        sim.cycle(k, k * dt, k * dt)
    assert sim.inputs["EStopActive"] and abs(sim.inputs["Beta_rad"] - b0) < 1e-9
    for k in range(10, 20):
        sim.write(_outputs(sim, ControllerHeartbeat=k + 1, EStopRequest=False, Mode="MANUAL"))
        sim.cycle(k, k * dt, k * dt)
    assert not sim.inputs["EStopActive"] and sim.inputs["Beta_rad"] > b0 + 1e-6


def _free_port() -> int:
    from loadarm.testing.loadtest import free_port

    return free_port()


def _plc_pair(tmp_path):
    """The controller's and the PLC's state directories, each trusting the other, the PLC's user for the
    controller, and an ephemeral endpoint."""
    from loadarm.opcua.server import APP_URI

    ctrl, plc = StateDir(tmp_path / "ctrl"), StateDir(tmp_path / "plc")
    ctrl.ensure(APP_URI)
    plc.ensure(PLC_APP_URI, "127.0.0.1")
    plc.trust(ctrl.cert)
    plc.users().add("controller", Role.ENGINEER, "pw-ctrl")
    return ctrl, plc, f"opc.tcp://127.0.0.1:{_free_port()}"


def _plc_process(plc, endpoint, *extra, plant=("--scenario", SCENARIO)):
    proc = subprocess.Popen([sys.executable, "-m", "loadarm.cli", "plc-sim", *plant, "--endpoint",
                             endpoint, "--state-dir", str(plc.path), *extra], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    assert "simulated PLC on" in line, line + proc.stderr.read()
    return proc


@contextlib.contextmanager
def _controller_on_plc_sim(tmp_path, scenario, *plc_args, period=0.02, speedup=1.0, **loop_kw):
    """``loadarm plc-sim`` (the drift-off) in its own process, the controller's link to it, and a guidance
    service on that link, not yet started; yields ``(loop, service, link, proc)``, then stops the service,
    the link and the process."""
    from loadarm.opcua.plc import PlcLink
    from loadarm.opcua.service import GuidanceService
    from loadarm.sim.loop import ClosedLoop

    sc, model = scenario
    ctrl, plc, endpoint = _plc_pair(tmp_path)
    proc = _plc_process(plc, endpoint, *plc_args)
    link = service = None
    try:
        link = PlcLink(endpoint, ctrl.path, "controller", "pw-ctrl", plc.cert, period=period)
        link.start()
        loop = ClosedLoop(sc, model, io=link, **loop_kw)
        service = GuidanceService(loop, speedup=speedup)
        yield loop, service, link, proc
    finally:
        if service is not None:
            service.stop()
        if link is not None:
            link.stop()
        proc.kill()
        proc.wait(10)


@pytest.mark.slow
@pytest.mark.realtime
def test_across_two_processes_a_jog_moves_the_plc_s_arm(tmp_path, scenario):
    """``loadarm plc-sim`` in its own process, the controller's link trusted by it (and it by the link): an
    operator's jog moves the PLC's arm through the link."""
    from loadarm.opcua.service import Request

    with _controller_on_plc_sim(tmp_path, scenario, scripted=False) as (loop, service, link, proc):
        q0 = link.q.copy()
        service.start()
        for _ in range(8):
            service.request(Request("jog", "alice", (0.0, 0.0, 0.2)))
            time.sleep(0.2)
        assert np.max(np.abs(link.q - q0)) > 1e-3 and link.link_ok and service.snapshot().plant_ok


@pytest.mark.slow
@pytest.mark.realtime
def test_the_plc_killed_mid_approach_is_caught_and_nothing_moves_after(tmp_path, scenario):
    """The PLC process killed while the scenario's operator has the arm on its approach: the controller marks
    the link dead within LINK_TIMEOUT plus a read period, raises the alarm, publishes its values as bad, stops
    commanding motion within a cycle (manual mode, zero rates) and keeps it stopped."""
    with _controller_on_plc_sim(tmp_path, scenario) as (loop, service, link, proc):
        service.start()
        t0 = time.monotonic()
        while service.snapshot() is None or service.snapshot().mode != "APPROACH":
            assert time.monotonic() - t0 < 10, "the approach did not start"
            time.sleep(0.05)
        time.sleep(1.0)
        assert any(abs(r) > 1e-4 for r in link._outputs_rates())
        proc.kill()
        killed = time.monotonic()
        while service.snapshot().plant_ok and time.monotonic() - killed < 5.0:
            time.sleep(0.005)
        reaction = time.monotonic() - killed
        print(f"PLC killed: link marked dead after {reaction:.3f} s")
        assert not service.snapshot().plant_ok and reaction <= LINK_TIMEOUT + 0.2, reaction
        assert any(e[2] == "alarm" and "PLC link lost" in e[3] for e in loop.events)
        time.sleep(2 * loop.dt + 0.05)
        seq = service.snapshot().seq
        for _ in range(10):                       # nothing commanded from then on
            assert link._outputs_rates() == (0.0, 0.0, 0.0) and service.snapshot().mode == "MANUAL"
            time.sleep(0.05)
        assert service.snapshot().seq > seq


@pytest.mark.slow
@pytest.mark.realtime
def test_hardware_in_the_loop_the_drift_off_across_two_processes_runs_the_same_modes(tmp_path, scenario):
    """The drift-off scenario with the controller in this process and the plant in ``loadarm plc-sim`` (both
    at 4x real time, the scenario's operator acting on the controller's side): the same mode sequence as the
    run in one process (the controller's alarms came from the estimate of the readings that crossed the
    link, through the PLC's buffer of its last readings). 4x, not faster: at 8x the Python PLC's server did not
    refresh its tags in time and the estimate went stale (found)."""
    from pathlib import Path

    from loadarm.sim.loop import run_scenario

    sc, model = scenario
    want = run_scenario(sc, model).summary()["mode_sequence"]
    with _controller_on_plc_sim(tmp_path, scenario, "--speedup", "4", period=0.01, speedup=4.0) as (loop, service,
                                                                                                    link, proc):
        service.start()
        assert service.finished.wait(sc.scenario.duration / 4 + 60)
        assert service.error is None
        got = loop.result().summary()["mode_sequence"]
        holds = [got[i - 1] for i in range(1, len(got)) if got[i] == "HOLD"]
        print(f"HIL drift-off: {got}; HOLD entered {len(holds)} time(s), from {holds}")
        assert _without_stale_holds(got) == want, (got, want)
        assert len(holds) <= MAX_HIL_HOLDS and set(holds) <= {"APPROACH", "STANDOFF"}, got
        assert ", ".join(want) in Path("docs/plant-integration.md").read_text().replace("\n", " ")


#: A loaded machine (CI: the realtime tests after 33 min of the suite on two cores) can deliver a reading late
#: enough that the estimate goes stale while the arm approaches: the controller then holds (zero rates) until it is
#: fresh and resumes, the safe response (found: CI of 2026-12-06, APPROACH, HOLD, APPROACH). At most this many
#: such holds, and only before the coupling: the connected part of the sequence must be exact.
MAX_HIL_HOLDS = 3


def _without_stale_holds(modes: list[str]) -> list[str]:
    """The mode sequence with each ``X, HOLD, X`` collapsed to ``X`` (HOLD is entered only by the fresh-estimate
    rule, :meth:`loadarm.guidance.rules.Rules.rule_fresh_estimate`); a HOLD that leads elsewhere is kept."""
    out: list[str] = []
    i = 0
    while i < len(modes):
        if modes[i] == "HOLD" and out and i + 1 < len(modes) and modes[i + 1] == out[-1]:
            i += 2
            continue
        out.append(modes[i])
        i += 1
    return out


def test_the_hil_comparison_collapses_only_a_hold_that_returns_to_the_mode_before_it():
    """The HIL test's tolerance for a late reading: the CI failure's sequence collapses to the one-process one;
    a HOLD that goes elsewhere, or a HOLD at the start, is kept (and fails the comparison)."""
    ci = ["STORED", "APPROACH", "HOLD", "APPROACH", "STANDOFF", "CONNECTED", "ALARM1", "RELEASE", "RETURN"]
    assert _without_stale_holds(ci) == ["STORED", "APPROACH", "STANDOFF", "CONNECTED", "ALARM1", "RELEASE",
                                        "RETURN"]
    assert _without_stale_holds(["STORED", "APPROACH", "HOLD", "STORED"]) == ["STORED", "APPROACH", "HOLD",
                                                                              "STORED"]
    assert _without_stale_holds(["HOLD", "STORED"]) == ["HOLD", "STORED"]
    assert _without_stale_holds(["A", "HOLD", "A", "HOLD", "A", "B"]) == ["A", "B"]


@pytest.mark.slow
@pytest.mark.realtime
def test_serve_on_a_plc_without_a_scenario_runs_on_and_an_operator_jogs_the_plc_s_arm(tmp_path):
    """``loadarm plc-sim --config`` (no scenario: a calm ship at the default flange) and ``loadarm serve --plc
    --config`` (no scenario: the controller runs on until stopped) in two processes; an OPC UA client logged in
    as an operator jogs the arm through the server, and the PLC's encoders show it moved."""
    import asyncio

    from asyncua import Client, ua
    from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256

    from loadarm.opcua.security import client_certificate
    from loadarm.opcua.server import NAMESPACE

    ctrl, plc, plc_endpoint = _plc_pair(tmp_path)
    plc_proc = _plc_process(plc, plc_endpoint, plant=("--config", "examples/paper.toml", "--duration", "600"))
    ctrl.users().add("alice", Role.OPERATOR, "pw-alice")
    cert, key = client_certificate(tmp_path / "client", "client", "urn:test:client")
    ctrl.trust(cert)
    (tmp_path / "pw").write_text("pw-ctrl\n")
    endpoint = f"opc.tcp://127.0.0.1:{_free_port()}"
    serve = subprocess.Popen([sys.executable, "-m", "loadarm.cli", "serve", "--config", "examples/paper.toml",
                              "--plc", plc_endpoint, "--plc-cert", str(plc.cert), "--plc-password-file",
                              str(tmp_path / "pw"), "--endpoint", endpoint, "--state-dir", str(ctrl.path), "--db",
                              str(tmp_path / "events.db")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    async def main():
        for _ in range(100):                          # the server is up once its first line is printed
            try:
                c = Client(endpoint, timeout=5)
                c.application_uri = "urn:test:client"
                c.set_user("alice")
                c.set_password("pw-alice")
                await c.set_security(SecurityPolicyBasic256Sha256, str(cert), str(key),
                                     server_certificate=str(ctrl.cert))
                await c.connect()
                break
            except (OSError, asyncio.TimeoutError, ua.UaError):
                await asyncio.sleep(0.2)
        else:
            raise AssertionError("serve did not come up: " + serve.stderr.read())
        try:
            ns = await c.get_namespace_index(NAMESPACE)
            guidance = c.get_node(ua.NodeId("Guidance", ns))
            var = (lambda name: c.get_node(ua.NodeId(f"Guidance.{name}", ns)))
            t0 = time.monotonic()
            while not await var("PlantLinkOK").read_value() or await var("Cycle").read_value() < 10:
                assert time.monotonic() - t0 < 20, "the controller never read the PLC"
                await asyncio.sleep(0.1)
            z0 = await var("CouplerZ_m").read_value()
            for _ in range(8):
                await guidance.call_method(ua.QualifiedName("Jog", ns), 0.0, 0.0, 0.15)
                await asyncio.sleep(0.2)
            await guidance.call_method(ua.QualifiedName("Stop", ns))
            await asyncio.sleep(0.3)
            return z0, await var("CouplerZ_m").read_value(), await var("Mode").read_value()
        finally:
            await c.disconnect()

    try:
        z0, z1, mode = asyncio.run(main())
        assert mode == "MANUAL" and z1 - z0 > 0.1, (z0, z1, mode)
        assert serve.poll() is None, "serve ended by itself: a PLC run has no end"
    finally:
        for proc in (serve, plc_proc):
            proc.terminate()
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(10)


def _map_text(tags):
    return "[tags]\n" + "".join(f'{k} = "{v[0]}"\n' if v[1] == 1.0 else f'{k} = {{ node = "{v[0]}", scale = {v[1]} }}\n'
                                for k, v in tags.items())


def test_a_mapping_file_round_trips_and_scales(tmp_path):
    from loadarm.opcua.plc import default_tag_map, load_tag_map

    m = default_tag_map().nodes
    m["Alpha_rad"] = ("ns=3;s=MLA.Inboard.Angle", 0.0174533)
    f = tmp_path / "map.toml"
    f.write_text(_map_text(m))
    assert load_tag_map(f).nodes == m


@pytest.mark.parametrize("edit, match", [
    (lambda m: m.pop("Beta_rad"), "tags.Beta_rad is not mapped"),
    (lambda m: m.update(Gamma=("ns=1;s=x", 1.0)), "unknown tag 'tags.Gamma'"),
    (lambda m: m.update(Phi_rad=("MLA.Slew", 1.0)), "tags.Phi_rad = 'MLA.Slew': a node id like"),
    (lambda m: m.update(Phi_rad=("ns=1;s=x", 0.0)), "tags.Phi_rad.scale = 0.0: a finite, non-zero number"),
    (lambda m: m.update(Connected=("ns=1;s=x", 2.0)), "only numeric tags scale, Connected is bool")])
def test_a_bad_mapping_file_is_refused_naming_the_file_and_tag(tmp_path, edit, match):
    from loadarm.errors import ConfigError
    from loadarm.opcua.plc import default_tag_map, load_tag_map

    m = default_tag_map().nodes
    edit(m)
    f = tmp_path / "map.toml"
    f.write_text(_map_text(m))
    with pytest.raises(ConfigError, match=match) as e:
        load_tag_map(f)
    assert str(e.value).startswith(str(f)) and "\n" not in str(e.value)


@pytest.mark.slow
@pytest.mark.realtime
def test_a_lost_link_reconnects_and_resynchronises_without_a_jump(tmp_path, scenario):
    """The PLC's OPC UA server stopped (its plant running on) and started again on the same endpoint: the link
    goes bad, comes back by itself, the controller logs it restored, and its encoders read on from where the
    arm stands (the watchdog held it: no jump)."""
    from loadarm.opcua.plc import PlcLink, PlcServer
    from loadarm.opcua.service import GuidanceService
    from loadarm.sim.loop import ClosedLoop

    sc, model = scenario
    ctrl, plc, endpoint = _plc_pair(tmp_path)
    sim = PlcSimulator(sc, model, plant="kinematic")
    server = PlcServer(sim, plc.path, endpoint)
    server.start()
    sim.start()
    link = service = None
    try:
        link = PlcLink(endpoint, ctrl.path, "controller", "pw-ctrl", plc.cert, period=0.02)
        link.start()
        loop = ClosedLoop(sc, model, scripted=False, io=link)
        service = GuidanceService(loop)
        service.start()
        time.sleep(0.5)
        server.stop()
        t0 = time.monotonic()
        while link.link_ok and time.monotonic() - t0 < 5:
            time.sleep(0.01)
        assert not link.link_ok
        q_dead = link.q.copy()
        server = PlcServer(sim, plc.path, endpoint)
        server.start()
        t0 = time.monotonic()
        while not service.snapshot().plant_ok and time.monotonic() - t0 < 10:
            time.sleep(0.01)
        assert service.snapshot().plant_ok and link.link_ok
        assert np.max(np.abs(link.q - q_dead)) < 1e-9
        kinds = [(e[2], e[3]) for e in loop.events]
        assert ("info", "PLC link restored") in kinds
    finally:
        if service is not None:
            service.stop()
        if link is not None:
            link.stop()
        sim.stop()
        server.stop()


def test_a_mapping_may_leave_the_line_loads_out_and_the_tag_table_says_so(tmp_path):
    """A PLC with no link to the berth's mooring load monitoring: its mapping leaves LineLoads out (the
    predictive alarms then never hold a change detector's call); every other tag is still required."""
    from loadarm.opcua.plc import OPTIONAL_TAGS, default_tag_map, load_tag_map, tags_markdown

    m = default_tag_map().nodes
    m.pop("LineLoads")
    f = tmp_path / "map.toml"
    f.write_text(_map_text(m))
    assert load_tag_map(f).nodes == m
    assert OPTIONAL_TAGS == ("LineLoads",) and "| `LineLoads` (optional) | PLC to controller | 1 |" in tags_markdown()


@pytest.mark.slow
def test_the_mooring_load_monitoring_crosses_the_plc_link(tmp_path):
    """The simulated PLC of a moored scenario publishes the monitoring's reading (each line's load, share of its
    MBL) and the controller's link hands it to the guidance as the plant's feedback, value for value; a PLC
    whose mapping leaves it out gives none."""
    import dataclasses

    from loadarm.opcua.plc import PlcLink, PlcServer, default_tag_map

    sc, model = load_scenario("examples/scenarios/hs15_moored.toml")
    sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"duration": 20.0})})
    ctrl, plc, endpoint = _plc_pair(tmp_path)
    sim = PlcSimulator(sc, model, plant="kinematic")
    sim.cycle(0, 0.0, 0.0)
    loads = sim.inputs["LineLoads"]
    assert len(loads) == 16 and all(0.0 < v < 0.6 for v in loads)          # taut lines, below their brakes
    assert tuple(loads) == sim.plant.feedback.line_loads
    server = PlcServer(sim, plc.path, endpoint)
    server.start()
    links = []
    try:
        unmapped = default_tag_map()
        unmapped = dataclasses.replace(unmapped, nodes={k: v for k, v in unmapped.nodes.items() if k != "LineLoads"})
        for tags in (None, unmapped):
            kw = {} if tags is None else {"tags": tags}
            link = PlcLink(endpoint, ctrl.path, "controller", "pw-ctrl", plc.cert, period=0.02, **kw)
            links.append(link)
            link.start()
        assert links[0].feedback.line_loads == tuple(loads)
        assert links[1].feedback.line_loads is None
    finally:
        for link in links:
            link.stop()
        server.stop()
