"""``loadarm serve``, ``loadarm plc-sim`` and ``loadarm trust``: beside a real PLC, over OPC UA, with the\noperator's
screen.
"""

from __future__ import annotations

import math
import signal
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import Annotated, Optional

import typer

from loadarm.cli.common import ForceOpt, UserError, check_outputs, latest_run, out, read_model
from loadarm.eventlog import EventLog, LogWriter
from loadarm.files import printable, read_input
from loadarm.hmi.app import HmiServer, create_app, parse_hmi_address, valid_host
from loadarm.hmi.bank import create_bank_app
from loadarm.hmi.replay import ReplayService
from loadarm.opcua.bank import BankServer, BankService
from loadarm.opcua.plc import PlcLink, PlcServer, PlcSimulator, load_tag_map
from loadarm.opcua.security import StateDir, load_certificate, thumbprint
from loadarm.opcua.server import OpcUaServer
from loadarm.opcua.service import REALTIME_SWITCH_INTERVAL, GuidanceService, freeze_heap
from loadarm.params.bank import load_bank
from loadarm.params.declare import in_range, range_text
from loadarm.params.scenario import Scenario, ScenarioHead, check_scenario
from loadarm.sim.bank import BankWorld
from loadarm.sim.loop import ClosedLoop
from loadarm.sim.spec import RunSpec, compile_run, load_run

#: On stop, ``serve`` waits this long for an unavailable event log to take the events it holds, s.
LOG_WAIT = 10.0
#: On stop, ``serve`` gives the OPC UA server and the screen this long each to end, s (their threads are daemons:
#: the process ends without them).
STOP_WAIT = 0.3
#: ``serve --plc`` waits this long for the PLC's first answer before it refuses to start, s.
PLC_WAIT = 10.0

__all__ = ["app"]

app = typer.Typer()


def _check_endpoint(name: str, value: str) -> None:
    from urllib.parse import urlparse

    try:
        url = urlparse(value)
        ok = url.scheme == "opc.tcp" and bool(url.hostname) and url.port is not None
        ok = ok and valid_host(url.hostname, ipv6=":" in url.hostname)
    except ValueError:                                   # a port out of range
        ok = False
    if not ok:
        raise UserError(f"{name} must be opc.tcp://HOST:PORT (an IPv4 address, a host name or [IPv6]; a port in "
                        f"[0, 65535]), got {value!r}")


def _one_line_logging() -> None:
    """The servers' log records as one line each on stderr, the text made printable, never a traceback (found: an
    untrusted client's certificate put asyncua's traceback into serve's output); asyncua's own notes below
    errors are dropped (loadarm logs the refusals that matter: a certificate, a login)."""
    import logging

    class _OneLine(logging.Formatter):
        def format(self, record):
            return printable(f"loadarm: {record.name}: {' '.join(record.getMessage().split())}")

    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_OneLine())
    root = logging.getLogger()
    root.handlers[:] = [handler]
    root.setLevel(logging.WARNING)
    for name in ("asyncua", "asyncuagds", "uvicorn", "distributed"):
        logging.getLogger(name).setLevel(logging.CRITICAL)


def _start_server(server) -> None:
    """Start an OPC UA server; one that cannot (its address is not this machine's, its port taken) is one line."""
    try:
        server.start()
    except RuntimeError as exc:
        raise UserError(' '.join(str(exc).split())) from None


def _stop_on_signals() -> None:
    """Ctrl-C (SIGINT) and SIGTERM stop a long-running command, whatever the process inherited. Found (issue 26,
    CI): a process started with SIGINT ignored (a test runner's worker, a shell's background job) kept ignoring
    it, and ``serve`` never stopped on the Ctrl-C it promises. The process is a real-time one: its control thread
    gets the interpreter within :data:`loadarm.opcua.service.REALTIME_SWITCH_INTERVAL`."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    sys.setswitchinterval(REALTIME_SWITCH_INTERVAL)


def _realtime_scenario(scenario: Optional[Path], config: Optional[Path], speedup: float, command: str,
                       duration: float | None = None) -> RunSpec:
    """The compiled run of a real-time command: its scenario and model (``--config``'s if given, checked against
    it); without a scenario, the default one (``duration`` long, if given) on ``--config``'s installation."""
    if not speedup > 0 or not math.isfinite(speedup):
        raise UserError(f"--speedup must be a positive number, got {speedup!r}")
    if scenario is None:
        if config is None:
            raise UserError(f"{command} without --scenario needs --config (the installation)")
        if duration is not None and not in_range(ScenarioHead, "duration", duration):
            raise UserError(f"--duration must be in {range_text(ScenarioHead, 'duration')}, got {duration!r}")
        model = read_model(config)
        head = {"name": config.stem} if duration is None else {"name": config.stem, "duration": duration}
        sc = Scenario.model_validate({"scenario": head})
        check_scenario(sc, model, source=f"the default scenario on {config}")
        return compile_run(sc, model)
    spec = load_run(scenario)
    if config is None:
        return spec
    model = read_model(config)
    check_scenario(spec.scenario, model, source=str(scenario))
    return compile_run(spec.scenario, model, berth=spec.berth, ship=spec.ship)


@app.command()
def serve(
    scenario: Annotated[Optional[Path], typer.Option(
        "--scenario", "-s", help="Scenario TOML: the simulated plant, ship and sensor the controller runs against "
                                 "(with --plc: only its [guidance] and [sensor] settings and its length).")] = None,
    config: Annotated[Optional[Path], typer.Option("--config", "-c", help="Installation TOML (default: the "
                                                                          "scenario's).")] = None,
    endpoint: Annotated[str, typer.Option("--endpoint", help="OPC UA endpoint to listen on (loopback unless "
                                                             "told otherwise).")] = "opc.tcp://127.0.0.1:4840",
    state_dir: Annotated[Path, typer.Option("--state-dir", help="Certificates, trust list and users (made on "
                                                                "first start).")] = Path("loadarm-state"),
    insecure: Annotated[bool, typer.Option("--insecure", help="Also offer the unsecured endpoint (a lab "
                                                              "only).")] = False,
    anonymous: Annotated[bool, typer.Option("--anonymous", help="Also accept anonymous, read-only OPC UA "
                                                                "sessions (off: every session is a user).")] = False,
    scripted: Annotated[bool, typer.Option("--scripted", help="The scenario's operator acts too (a "
                                                              "demonstration).")] = False,
    db: Annotated[Path, typer.Option("--db", help="SQLite event log (operator actions with the user's "
                                                  "name).")] = Path("loadarm-events.db"),
    speedup: Annotated[float, typer.Option("--speedup", help="Run seconds per wall second.")] = 1.0,
    plc: Annotated[Optional[str], typer.Option("--plc", help="A PLC's OPC UA endpoint (loadarm plc-sim, or a "
                                                             "real one): the plant is read from and "
                                                             "commanded through it.")] = None,
    plc_cert: Annotated[Optional[Path], typer.Option("--plc-cert", help="The PLC's certificate (DER or "
                                                                        "PEM), as you trust it.")] = None,
    plc_user: Annotated[str, typer.Option("--plc-user", help="The PLC's user for the controller.")] = "controller",
    plc_password_file: Annotated[Optional[Path], typer.Option(
        "--plc-password-file", help="File whose first line is that user's password.")] = None,
    plc_map: Annotated[Optional[Path], typer.Option("--plc-map", help="Where each tag is on the PLC (TOML; "
                                                                      "default loadarm plc-sim's nodes).")] = None,
    hmi: Annotated[Optional[str], typer.Option("--hmi", help="Serve the operator's web screen on HOST:PORT "
                                                             "(e.g. 127.0.0.1:8080; loopback unless told "
                                                             "otherwise).")] = None,
    replay: Annotated[Optional[Path], typer.Option("--replay", help="Replay a logged run on the screen (an "
                                                                    "event log; needs --hmi) instead of "
                                                                    "running the controller.")] = None,
    run_id: Annotated[Optional[str], typer.Option("--run", help="The run to replay (default the latest).")] = None,
    bank: Annotated[Optional[Path], typer.Option("--bank", help="Serve a bank of arms (a bank file) instead of one "
                                                                "arm: every arm connected to --scenario's ship, "
                                                                "read-only.")] = None,
    force: ForceOpt = False,
) -> None:
    """Run the guidance controller in real time against a scenario's simulated plant (or a PLC) and serve it over
    OPC UA (Basic256Sha256 / Aes128 / Aes256, SignAndEncrypt; users and roles from STATE_DIR/users.toml;
    client certificates trusted from STATE_DIR/pki/trusted). With --plc and no --scenario it runs until
    stopped, with the default guidance and sensor settings, on --config's installation. Ctrl-C stops.

    With --bank: the bank's world, every arm connected to the scenario's (moored) ship, served read-only (one OPC UA
    object per arm under the bank, and the bank's screen with --hmi).

    Example: loadarm serve --scenario examples/scenarios/driftoff.toml --state-dir out/state
    """

    if bank is not None:
        other = [("--plc", plc), ("--replay", replay), ("--config", config), ("--scripted", scripted)]
        return _serve_bank(bank, scenario, endpoint, state_dir, insecure, anonymous, speedup, hmi, other=other,
                           db=db, force=force)
    hmi_address = _serve_arguments(endpoint, hmi, replay, plc, plc_cert, plc_password_file, scenario, scripted)
    _stop_on_signals()
    _one_line_logging()
    if replay is not None:
        return _serve_replay(replay, run_id, scenario, config, state_dir, hmi_address)
    spec = _realtime_scenario(scenario, config, speedup, "serve --plc")
    sc, model = spec.scenario, spec.model
    inst_file = None if scenario is None or sc.scenario.installation is None \
        else scenario.parent / sc.scenario.installation
    check_outputs({"--db": db}, [scenario, inst_file, config], force, appended=("--db",))
    run_id = f"serve:{sc.scenario.name}@{datetime.now(timezone.utc).strftime('%Y%m%dT%H%M%S.%fZ')}"
    link = None if plc is None else _plc_link(plc, plc_map, plc_password_file, state_dir, plc_user, plc_cert)
    interrupted, said = False, []
    service = None
    log = LogWriter(EventLog(db, run=run_id))     # off the control path: a locked log or a full disk is an alarm
    try:
        loop = ClosedLoop(sc, model, log=log, scripted=scripted, io=link, continuous=scenario is None,
                          ship=spec.ship)
        loop.warm_up()                      # compiled before the clock starts and before "Ctrl-C stops"
        service = GuidanceService(loop, speedup=speedup)
        server = OpcUaServer(service, state_dir, endpoint, insecure=insecure, name=sc.scenario.name,
                             anonymous=anonymous)
        _start_server(server)
        screen = None
        try:
            if hmi_address is not None:
                screen = _start_screen(service, state_dir, model, sc.scenario.name, hmi_address, server)
            _announce(server, endpoint, insecure, state_dir)
            out.print(f"events to {db} (run {run_id}); Ctrl-C stops")
            freeze_heap()                       # the collector's full passes: only what comes after
            service.run()
        finally:
            _say_stopped(service, said)         # at once: the servers' ends below take their own time
            if screen is not None:
                screen.stop(timeout=STOP_WAIT)
            server.stop(timeout=STOP_WAIT)      # bounded (daemon threads): a Ctrl-C ends the process within 1 s
    except KeyboardInterrupt:   # the documented way to stop (found: a Ctrl-C just after the line that says so, before
        interrupted = True      # the loop's own handler, left no "stopped at" line): say where, then exit 130
    finally:
        unwritten = log.close(timeout=LOG_WAIT)
        if link is not None:
            link.stop()
    if unwritten:
        out.print(f"event log {db}: {log.status().unwritten(unwritten, LOG_WAIT)}")
    _say_stopped(service, said)
    if interrupted:
        raise KeyboardInterrupt


def _serve_bank(bank_file: Path, scenario: Optional[Path], endpoint: str, state_dir: Path, insecure: bool,
                anonymous: bool, speedup: float, hmi: Optional[str], other, db: Path, force: bool) -> None:
    """``serve --bank``: the bank's kinematic world on the scenario's ship in real time, its OPC UA server and,
    with ``--hmi``, its screen, until the scenario's end or Ctrl-C; its events in the event log ``db``."""
    given = [name for name, value in other if value]
    if given:
        raise UserError(f"--bank serves the bank's kinematic world: {', '.join(given)} cannot go with it")
    if scenario is None:
        raise UserError("--bank needs --scenario: the ship (and sea) every arm is connected to")
    _check_endpoint("--endpoint", endpoint)
    try:
        hmi_address = None if hmi is None else parse_hmi_address(hmi)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    _stop_on_signals()
    _one_line_logging()
    spec = _realtime_scenario(scenario, None, speedup, "serve --bank")
    bank = load_bank(bank_file)
    check_outputs({"--db": db}, [scenario, bank_file, *bank.paths], force, appended=("--db",))
    run_id = f"serve-bank:{bank.file.bank.name}@{datetime.now(timezone.utc).strftime('%Y%m%dT%H%M%S.%fZ')}"
    log = LogWriter(EventLog(db, run=run_id))     # off the bank's thread: a locked log or a full disk is a note
    try:
        _serve_bank_logged(bank, scenario, spec, endpoint, state_dir, insecure, anonymous, speedup, hmi_address, log)
    finally:
        unwritten = log.close(timeout=LOG_WAIT)
        if unwritten:
            out.print(f"event log {db}: {log.status().unwritten(unwritten, LOG_WAIT)}")


def _serve_bank_logged(bank, scenario: Path, spec, endpoint: str, state_dir: Path, insecure: bool, anonymous: bool,
                       speedup: float, hmi_address, log) -> None:
    """``serve --bank`` once its event log is open."""
    service = BankService(BankWorld.from_scenario(bank, spec.scenario, spec.ship), speedup=speedup, log=log)
    server = BankServer(service, state_dir, endpoint, insecure=insecure, anonymous=anonymous)
    _start_server(server)
    screen = None
    try:
        if hmi_address is not None:
            screen = HmiServer(create_bank_app(service, state_dir, berth=spec.berth), *hmi_address)
            try:
                screen.start()
            except OSError as exc:
                raise UserError(str(exc)) from None
            out.print(f"bank's screen on {screen.url} (users from {server.state.users_file})")
        _announce(server, endpoint, insecure, state_dir)
        names = ", ".join(service.bank.names)
        started = (f"bank {service.bank.file.bank.name}: {names} connected to the ship of {scenario.name} "
                   f"({spec.scenario.scenario.duration:g} s at {speedup:g}x)")
        log.append(0.0, service.stage_name(), "info", started, arms=list(service.bank.names), scenario=scenario.name)
        out.print(f"{started}; events to {log.path} (run {log.run}); Ctrl-C stops", soft_wrap=True)
        sys.stdout.flush()
        freeze_heap()
        service.run()
    finally:                # the closing line at once, Ctrl-C or the scenario's end; then the servers' ends
        snap = service.snapshot()
        stopped = f"stopped at t = {snap.state.t if snap else 0.0:.1f} s; {service.late} late states"
        log.append(snap.state.t if snap else 0.0, service.stage_name(), "info", stopped, late=service.late)
        out.print(stopped)
        sys.stdout.flush()
        if screen is not None:
            screen.stop(timeout=STOP_WAIT)
        server.stop(timeout=STOP_WAIT)


def _say_stopped(service, said: list) -> None:
    """The closing line, once (``said`` remembers): where the run stopped (found, issue 29: a Ctrl-C printed it
    only after the OPC UA server's and the screen's ends, about 6 s with clients connected)."""
    if service is None or said:
        return
    said.append(True)
    snap = service.snapshot()
    if snap is not None:
        out.print(f"stopped at t = {snap.t:.1f} s in {snap.mode}; {snap.late} late cycles")
    else:                                   # a Ctrl-C before the first cycle (found: it said nothing)
        out.print("stopped at t = 0.0 s, before the first cycle; 0 late cycles")
    sys.stdout.flush()


def _serve_arguments(endpoint, hmi, replay, plc, plc_cert, plc_password_file, scenario, scripted):
    """``serve``'s options checked together, before anything starts; the screen's address (or None)."""
    _check_endpoint("--endpoint", endpoint)
    hmi_address = None
    if hmi is not None:
        try:
            hmi_address = parse_hmi_address(hmi)
        except ValueError as exc:
            raise UserError(str(exc)) from None
    if replay is not None:
        return hmi_address
    if plc is not None:
        _check_endpoint("--plc", plc)
        if plc_cert is None or plc_password_file is None:
            raise UserError("--plc needs --plc-cert (the PLC's certificate) and --plc-password-file")
    elif scenario is None:
        raise UserError("serve needs --scenario (a simulated plant) or --plc (a PLC's endpoint)")
    if scripted and scenario is None:
        raise UserError("--scripted needs --scenario (its operator is the scenario's)")
    return hmi_address


def _plc_link(plc, plc_map, plc_password_file, state_dir, plc_user, plc_cert):
    """The controller's link to a PLC, started (its password from the first line of the file)."""
    tags = load_tag_map(plc_map) if plc_map is not None else None
    lines = read_input(plc_password_file, "password").splitlines()
    if not lines or not lines[0]:
        raise UserError(f"--plc-password-file {plc_password_file}: its first line is empty")
    load_certificate(plc_cert)                  # found: a missing one gave 30 s of silence, then an internal error
    link = PlcLink(plc, state_dir, plc_user, lines[0], plc_cert, tags=tags)
    try:
        link.start(timeout=PLC_WAIT)
    except RuntimeError as exc:
        raise UserError(f"--plc {plc}: {' '.join(str(exc).split())}") from None
    return link


def _start_screen(service, state_dir, model, name: str, hmi_address, server):
    """The operator's screen beside the OPC UA server, started (a port in use is one line)."""
    screen = HmiServer(create_app(service, state_dir, model, name=name), *hmi_address)
    try:
        screen.start()
    except OSError as exc:
        raise UserError(str(exc)) from None
    out.print(f"operator's screen on {screen.url} (users from {server.state.users_file})")
    return screen


def _announce(server, endpoint: str, insecure: bool, state_dir) -> None:
    """Where the server listens, its certificate, and who can log in."""
    cert = load_certificate(server.state.cert)
    out.print(f"OPC UA server on {endpoint} ({'with' if insecure else 'no'} unsecured endpoint); "
              f"certificate {server.state.cert} (SHA-1 {thumbprint(cert)})")
    users = server.state.users()
    out.print(f"{len(users)} user(s) in {server.state.users_file}; trusted clients in {server.state.trusted}")
    if len(users) == 0:
        out.print(f"no one can log in yet: add a user with loadarm user add NAME --role operator "
                  f"--state-dir {state_dir}", soft_wrap=True)


def _serve_replay(db: Path, run_id: Optional[str], scenario: Optional[Path], config: Optional[Path], state_dir: Path,
                  hmi_address) -> None:
    """``serve --replay``: the screen over a logged run (no controller, no OPC UA server), until Ctrl-C."""
    import time as _time

    if hmi_address is None:
        raise UserError("--replay needs --hmi HOST:PORT (the screen it replays on)")
    if scenario is None and config is None:
        raise UserError("--replay needs --config (or --scenario): the installation the run was made on")
    model = read_model(config) if config is not None else _realtime_scenario(scenario, None, 1.0, "serve").model
    log = EventLog.open_existing(db)
    try:
        events = log.query(run=run_id) if run_id is not None else log.query()
    finally:
        log.close()
    if run_id is None:
        run_id, events = latest_run(events, f"--replay {db}: no run with state samples in the log")
    if not events:
        raise UserError(f"--run {run_id!r}: no such run in {db}")
    service = ReplayService(events, model)
    users = StateDir(state_dir).users()
    if len(users) == 0:
        raise UserError(f"--state-dir {state_dir}: no users to log in with (add one: loadarm user add NAME "
                        f"--role viewer --state-dir {state_dir})")
    screen = HmiServer(create_app(service, state_dir, model, name=f"replay of {run_id}"), *hmi_address)
    try:
        screen.start()
    except OSError as exc:
        raise UserError(str(exc)) from None
    try:
        out.print(f"replay of run {run_id} ({service.t0:.0f}-{service.t1:.0f} s, {len(service.samples)} samples) "
                  f"on {screen.url}; Ctrl-C stops", soft_wrap=True)
        sys.stdout.flush()
        while True:
            _time.sleep(0.5)
    finally:
        screen.stop()


@app.command("plc-sim")
def plc_sim(
    scenario: Annotated[Optional[Path], typer.Option(
        "--scenario", "-s", help="Scenario TOML: the plant, ship and sensor the PLC simulates (default: a calm "
                                 "ship at the default flange, on --config's installation).")] = None,
    config: Annotated[Optional[Path], typer.Option("--config", "-c", help="Installation TOML (default: the "
                                                                          "scenario's).")] = None,
    endpoint: Annotated[str, typer.Option("--endpoint", help="OPC UA endpoint to listen on.")] =
        "opc.tcp://127.0.0.1:4841",
    state_dir: Annotated[Path, typer.Option("--state-dir", help="The PLC's certificates, trust list and "
                                                                "users.")] = Path("loadarm-plc-state"),
    insecure: Annotated[bool, typer.Option("--insecure", help="Also offer the unsecured endpoint.")] = False,
    speedup: Annotated[float, typer.Option("--speedup", help="PLC seconds per wall second (as serve's).")] = 1.0,
    duration: Annotated[float, typer.Option("--duration", help="Seconds simulated without --scenario.")] = 3600.0,
) -> None:
    """A simulated PLC: the scenario's arm, valve drivers (with a watchdog on the controller's heartbeat), ERS
    valves, flange tracker and hard-wired E-stop in real time, served over OPC UA for `loadarm serve --plc`.
    Ctrl-C stops.

    Example: loadarm plc-sim --scenario examples/scenarios/driftoff.toml --state-dir out/plc
    """

    _check_endpoint("--endpoint", endpoint)
    _stop_on_signals()
    _one_line_logging()
    spec = _realtime_scenario(scenario, config, speedup, "plc-sim", duration)
    sim = PlcSimulator(spec.scenario, spec.model, speedup=speedup, ship=spec.ship)
    server = PlcServer(sim, state_dir, endpoint, insecure=insecure)
    _start_server(server)
    try:
        out.print(f"simulated PLC on {endpoint}; certificate {server.state.cert}; "
                  f"{len(server.state.users())} user(s); Ctrl-C stops", soft_wrap=True)
        sys.stdout.flush()
        sim.plant.warm_up()                     # compiled, then frozen (its run's own warm-up is then at once)
        freeze_heap()
        sim.run()
    finally:
        server.stop(timeout=STOP_WAIT)


@app.command()
def trust(
    cert: Annotated[Path, typer.Argument(help="Client certificate (DER or PEM).")],
    state_dir: Annotated[Path, typer.Option("--state-dir", help="The server's state directory.")] = Path("loadarm-state"),
) -> None:
    """Trust an OPC UA client's certificate (copied to STATE_DIR/pki/trusted; a running server reads it at its
    next start).

    Example: loadarm trust client.der --state-dir out/state
    """

    out.print(f"trusted: {StateDir(state_dir).trust(cert)} (effective at the server's next start)")
