"""``loadarm serve`` starts without a certificate warning and stops within a second of Ctrl-C with its closing
line (issue 29, item 17)."""

from __future__ import annotations

import ipaddress
import os
import signal
import socket
import subprocess
import sys
import time

import pytest

from .conftest import ROOT


def test_the_self_made_certificate_names_this_host(tmp_path):
    """asyncua (and clients) compare the host's name with the certificate's DNS names: found, every serve start
    said "certificate does not contain the hostname in DNSNames vm"."""
    from cryptography import x509

    from loadarm.opcua.security import StateDir, load_certificate

    st = StateDir(tmp_path / "st")
    st.ensure("urn:loadarm:test", "127.0.0.1")
    san = load_certificate(st.cert).extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    dns = set(san.get_values_for_type(x509.DNSName))
    ips = set(san.get_values_for_type(x509.IPAddress))
    assert {socket.gethostname(), socket.getfqdn(), "localhost"} <= dns and "127.0.0.1" not in dns
    assert ipaddress.ip_address("127.0.0.1") in ips
    assert san.get_values_for_type(x509.UniformResourceIdentifier) == ["urn:loadarm:test"]


@pytest.mark.slow
@pytest.mark.realtime
def test_serve_stops_within_a_second_of_ctrl_c_with_its_closing_line(tmp_path):
    from loadarm.opcua.security import Role, StateDir
    from loadarm.testing.loadtest import free_port

    st = StateDir(tmp_path / "st")
    st.users().add("alice", Role.OPERATOR, "pw-alice")
    proc = subprocess.Popen([sys.executable, "-u", "-m", "loadarm.cli", "serve", "--scenario",
                             str(ROOT / "examples" / "scenarios" / "calm.toml"), "--state-dir", str(st.path),
                             "--endpoint", f"opc.tcp://127.0.0.1:{free_port()}", "--hmi", f"127.0.0.1:{free_port()}",
                             "--db", str(tmp_path / "ev.db")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    try:
        lines = []
        for line in proc.stdout:
            lines.append(line)
            if "Ctrl-C stops" in line:
                break
        assert lines and "Ctrl-C stops" in lines[-1], "".join(lines) + proc.stderr.read()
        time.sleep(1.0)
        t0 = time.monotonic()
        os.killpg(proc.pid, signal.SIGINT)
        closing = proc.stdout.readline()
        said = time.monotonic() - t0
        code = proc.wait(10)
        gone = time.monotonic() - t0
        err = proc.stderr.read()
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait(10)
    assert closing.startswith("stopped at t = ") and "late cycles" in closing, closing + err
    assert code == 130 and said < 1.0 and gone < 1.0, (said, gone, err)
    assert "DNSNames" not in err and "Traceback" not in err, err
