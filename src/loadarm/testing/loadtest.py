"""Load on the OPC UA server (issue 14, item 6): many clients, each subscribed to every variable of the guidance
object, in a process of their own (``python -m loadarm.testing.loadtest``), counting the data-change notifications
they receive; and the method round trip. Used by the load test and by ``make bench``."""

from __future__ import annotations

import argparse
import asyncio
import gc
import json
import sys
import time

from loadarm.opcua.security import Role, StateDir, client_certificate
from loadarm.opcua.server import NAMESPACE, STATES, VARIABLES, OpcUaServer
from loadarm.opcua.service import REALTIME_SWITCH_INTERVAL, GuidanceService, freeze_heap
from loadarm.params.scenario import load_scenario
from loadarm.sim.loop import ClosedLoop

__all__ = ["subscribe_all", "call_round_trips", "measure_load", "free_port", "main"]


async def _client(endpoint: str, user: str, password: str, cert: str, key: str, server_cert: str, app_uri: str):
    from asyncua import Client
    from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256

    c = Client(endpoint, timeout=10)
    c.application_uri = app_uri
    c.set_user(user)
    c.set_password(password)
    await c.set_security(SecurityPolicyBasic256Sha256, cert, key, server_certificate=server_cert)
    return c


async def _variables(c):
    from asyncua import ua

    ns = await c.get_namespace_index(NAMESPACE)
    names = [v[0] for v in VARIABLES] + [s[0] for s in STATES]
    return ns, [c.get_node(ua.NodeId(f"Guidance.{n}", ns)) for n in names]


async def subscribe_all(endpoint: str, user: str, password: str, cert: str, key: str, server_cert: str,
                        app_uri: str, *, clients: int = 20, seconds: float = 10.0, interval_ms: float = 100.0) -> dict:
    """``clients`` sessions, each subscribed to every guidance variable at ``interval_ms``, for ``seconds``.

    Parameters
    ----------
    endpoint : str
    user, password : str
        A viewer suffices.
    cert, key : str
        The client's certificate and key (trusted by the server).
    server_cert : str
        The server's certificate.
    app_uri : str
        The client's application URI (its certificate's).
    clients : int
    seconds : float
    interval_ms : float
        Publishing interval.

    Returns
    -------
    dict
        ``clients``, ``variables``, ``notifications`` (data changes received in the window), ``seconds``,
        ``cpu_s`` (this process's CPU time in the window).
    """
    class Count:
        n = 0

        def datachange_notification(self, node, val, data):
            Count.n += 1

    sessions = [await _client(endpoint, user, password, cert, key, server_cert, app_uri) for _ in range(clients)]
    nvars = 0
    try:
        for c in sessions:
            await c.connect()
        for c in sessions:
            _, nodes = await _variables(c)
            nvars = len(nodes)
            sub = await c.create_subscription(interval_ms, Count())
            await sub.subscribe_data_change(nodes, sampling_interval=interval_ms)
        await asyncio.sleep(1.0)                       # the initial values arrive first
        Count.n = 0
        cpu0, t0 = time.process_time(), time.perf_counter()
        await asyncio.sleep(seconds)
        n, wall, cpu = Count.n, time.perf_counter() - t0, time.process_time() - cpu0
    finally:
        for c in sessions:
            try:
                await c.disconnect()
            except Exception:
                pass
    return {"clients": clients, "variables": nvars, "notifications": n, "seconds": wall, "cpu_s": cpu}


async def call_round_trips(endpoint: str, user: str, password: str, cert: str, key: str, server_cert: str,
                           app_uri: str, *, calls: int = 200) -> dict:
    """Method calls (``AcknowledgeAlarm``) and plain reads of one variable, timed one after the other on one
    secure session: the read is the protocol's own round trip, the peer of the call.

    Parameters
    ----------
    endpoint, user, password, cert, key, server_cert, app_uri : str
        As :func:`subscribe_all` (an operator: it calls).
    calls : int

    Returns
    -------
    dict
        ``call_ms`` and ``read_ms``: lists of round trips, ms.
    """
    from asyncua import ua

    c = await _client(endpoint, user, password, cert, key, server_cert, app_uri)
    async with c:
        ns, nodes = await _variables(c)
        guidance = c.get_node(ua.NodeId("Guidance", ns))
        ack = ua.QualifiedName("AcknowledgeAlarm", ns)
        call_ms, read_ms = [], []
        for _ in range(calls):
            t0 = time.perf_counter()
            await guidance.call_method(ack)
            t1 = time.perf_counter()
            await nodes[0].read_value()
            t2 = time.perf_counter()
            call_ms.append((t1 - t0) * 1e3)
            read_ms.append((t2 - t1) * 1e3)
    return {"call_ms": call_ms, "read_ms": read_ms}


def free_port() -> int:
    """An ephemeral loopback port free now (for a server a test or benchmark starts).

    Returns
    -------
    int
    """
    import socket

    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def measure_load(workdir, scenario, *, seconds: float = 10.0, clients: int = 20, calls: int = 0,
                 interval_ms: float = 100.0, quiet: float = 3.0) -> dict:
    """Serve a real guidance service (the scenario, its operator acting: the arm moves, the values change) on
    an ephemeral loopback port, put ``clients`` sessions subscribed to every variable at 10 Hz on it from
    another process for ``seconds`` (:func:`subscribe_all`), and time ``calls`` method round trips
    (:func:`call_round_trips`) after; stop everything.

    Parameters
    ----------
    workdir : path
        A scratch folder (the state directory and the client's certificate).
    scenario : path
    seconds : float
    clients : int
    calls : int
    interval_ms : float
        The publishing and sampling interval the clients ask for (10: hostile clients; the server revises it).
    quiet : float
        Seconds the loop runs before the clients come (the cycles "before").

    Returns
    -------
    dict
        The clients' counts, ``server_cpu_s`` (this process's CPU time during the load: the control loop and the
        server), ``cycle_us_before`` and ``cycle_us_during`` (ndarrays), ``late`` (cycles during the load started
        late) and ``late_at`` (each: cycle from the load's start, s late), and
        ``call_ms`` / ``read_ms`` when ``calls``.
    """
    import json
    import subprocess
    from pathlib import Path

    workdir = Path(workdir)
    st = StateDir(workdir / "state")
    st.users().add("viewer", Role.VIEWER, "pw-viewer")
    st.users().add("operator", Role.OPERATOR, "pw-operator")
    cert, key = client_certificate(workdir, "load", "urn:loadarm:loadtest")
    st.trust(cert)
    sc, model = load_scenario(scenario)
    previous = sys.getswitchinterval()
    sys.setswitchinterval(REALTIME_SWITCH_INTERVAL)          # as loadarm serve does
    service = GuidanceService(ClosedLoop(sc, model))
    endpoint = f"opc.tcp://127.0.0.1:{free_port()}"
    server = OpcUaServer(service, st.path, endpoint)
    server.start()
    out: dict = {}
    try:
        service.loop.warm_up()                               # as loadarm serve does: compiled, then frozen
        freeze_heap()
        service.start()
        ready = time.monotonic() + 60.0                # the first cycle (numba's cache loaded) before the quiet
        while service.snapshot() is None and service.error is None and time.monotonic() < ready:
            time.sleep(0.05)
        if service.snapshot() is None:
            raise RuntimeError(f"the guidance service made no cycle in 60 s: {service.error!r}")
        time.sleep(quiet)
        k0, cpu0 = service.snapshot().seq, time.process_time()
        proc = subprocess.run([sys.executable, "-m", "loadarm.testing.loadtest", endpoint, "viewer", "pw-viewer",
                               str(cert), str(key), str(st.cert), "urn:loadarm:loadtest", "--clients", str(clients),
                               "--seconds", str(seconds), "--interval-ms", str(interval_ms)],
                              capture_output=True, text=True, timeout=seconds + 120)
        k1, cpu1 = service.snapshot().seq, time.process_time()
        late_tail = [(k, lag) for k, lag in service.late_tail if k0 <= k < k1]
        if calls:
            out.update(asyncio.run(call_round_trips(endpoint, "operator", "pw-operator", str(cert), str(key),
                                                    str(st.cert), "urn:loadarm:loadtest", calls=calls)))
    finally:
        service.stop()
        server.stop()
        sys.setswitchinterval(previous)
        gc.unfreeze()
    if proc.returncode != 0:
        raise RuntimeError(f"the load clients failed: {proc.stderr.strip()[-500:]}")
    out.update(json.loads(proc.stdout.strip().splitlines()[-1]))
    cyc = service.loop.cycle_us
    out.update(server_cpu_s=cpu1 - cpu0, cycle_us_before=cyc[:k0], cycle_us_during=cyc[k0:k1], late=len(late_tail),
               late_at=[(k - k0, lag) for k, lag in late_tail])
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m loadarm.testing.loadtest ENDPOINT USER PASSWORD CERT KEY SERVER_CERT APP_URI [--clients N]
    [--seconds S]``: print :func:`subscribe_all`'s result as JSON.

    Parameters
    ----------
    argv : list of str, optional

    Returns
    -------
    int
        Exit status.
    """
    p = argparse.ArgumentParser(prog="python -m loadarm.testing.loadtest")
    for name in ("endpoint", "user", "password", "cert", "key", "server_cert", "app_uri"):
        p.add_argument(name)
    p.add_argument("--clients", type=int, default=20)
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--interval-ms", type=float, default=100.0)
    a = p.parse_args(argv)
    res = asyncio.run(subscribe_all(a.endpoint, a.user, a.password, a.cert, a.key, a.server_cert, a.app_uri,
                                    clients=a.clients, seconds=a.seconds, interval_ms=a.interval_ms))
    print(json.dumps(res))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
