"""Security of the plant interface (issue 14, item 3): the application certificate, the trust list, the users.

Everything lives in one state directory (``--state-dir``)::

    STATE_DIR/
      own/cert.der        the application instance certificate (self-signed, made on first start)
      own/key.pem         its private key (mode 0600; refused if anyone else may read it)
      pki/trusted/        client certificates trusted (a copy of one here is trusted after a restart;
                          ``loadarm trust CERT --state-dir DIR`` puts one there)
      pki/rejected/       certificates of clients refused, kept for the administrator to inspect
      users.toml          users, their roles and scrypt password hashes (``loadarm user add``)

Roles (:class:`Role`), each including the one before: **viewer** (browse, read, subscribe), **operator** (the
methods: approach, connect, jog, stop, E-stop, ESD-1, ERS, reset, acknowledge), **engineer** (writes to the
parameters). Anonymous sessions are viewers at most.

Passwords are hashed with scrypt (:func:`hashlib.scrypt`; n = 2^14, r = 8, p = 1, a 16-byte salt: RFC 7914's
interactive-login cost) and compared in constant time.
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import os
import re
import secrets
import stat
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from loadarm.errors import ConfigError
from loadarm.files import atomic_write, read_binary, read_toml
from loadarm.vocab import Role

__all__ = ["Role", "User", "Users", "LiveUsers", "StateDir", "hash_password", "verify_password", "SCRYPT", "SECRET_BYTES",
           "LOGIN_FAILURES", "LOGIN_WINDOW", "LoginLimiter", "is_user_name", "client_certificate", "thumbprint",
           "host_names"]

#: scrypt cost (n, r, p) and salt length, bytes.
SCRYPT = (2 ** 14, 8, 1)
SALT_BYTES = 16
#: The longest password accepted, in UTF-8 bytes: a longer one is refused before any hashing (found: ``user
#: add`` took a 2 MB password, and the screen hashed a 5 MB one).
SECRET_BYTES = 1024
#: Failed logins allowed per user name and per client in :data:`LOGIN_WINDOW` (the screen's and the OPC UA
#: server's: a client is an address on the screen, a certificate on OPC UA).
LOGIN_FAILURES = 5
#: The window of :data:`LOGIN_FAILURES`, s.
LOGIN_WINDOW = 60.0
_NAME = re.compile(r"^[A-Za-z0-9_.@-]{1,64}$")


def is_user_name(name) -> bool:
    """Whether ``name`` could be a user of the users file (1-64 letters, digits or ``_.@-``): anything else is
    refused before a login limit or a log line is spent on it.

    Parameters
    ----------
    name : object

    Returns
    -------
    bool
    """
    return isinstance(name, str) and _NAME.fullmatch(name) is not None


@dataclass(frozen=True)
class User:
    """A user of the plant interface.

    Attributes
    ----------
    name : str
    role : Role
    """

    name: str
    role: Role


def hash_password(password: str, *, salt: bytes | None = None) -> str:
    """An scrypt hash of ``password``, as ``scrypt$n$r$p$salt_hex$hash_hex``.

    Parameters
    ----------
    password : str
    salt : bytes, optional
        Random (:data:`SALT_BYTES`) unless given (tests).

    Returns
    -------
    str
    """
    if not password:
        raise ConfigError("a password may not be empty")
    if len(password.encode()) > SECRET_BYTES:
        raise ConfigError(f"a password may have at most {SECRET_BYTES} bytes, got {len(password.encode())}")
    n, r, p = SCRYPT
    salt = secrets.token_bytes(SALT_BYTES) if salt is None else salt
    digest = hashlib.scrypt(password.encode(), salt=salt, n=n, r=r, p=p, dklen=32)
    return f"scrypt${n}${r}${p}${salt.hex()}${digest.hex()}"


def verify_password(password: str, stored: str) -> bool:
    """Whether ``password`` matches a hash of :func:`hash_password` (constant-time comparison).

    Parameters
    ----------
    password, stored : str

    Returns
    -------
    bool
    """
    try:
        kind, n, r, p, salt, digest = stored.split("$")
        if kind != "scrypt":
            return False
        got = hashlib.scrypt(password.encode(), salt=bytes.fromhex(salt), n=int(n), r=int(r), p=int(p),
                             dklen=len(digest) // 2)
    except (ValueError, TypeError):
        return False
    return hmac.compare_digest(got.hex(), digest)


@functools.lru_cache(maxsize=1)
def _dummy_hash() -> str:
    return hash_password("x", salt=b"\0" * SALT_BYTES)


class Users:
    """The users file: ``[users.NAME] role = "operator", password = "scrypt$..."``.

    Parameters
    ----------
    path : Path
        ``users.toml``; a missing file means no users (anonymous viewers only).
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        self._entries: dict[str, tuple[Role, str]] = {}
        if self.path.exists():
            self._load()

    def _load(self) -> None:

        src = str(self.path)
        data = read_toml(self.path, "users file")
        users = data.get("users", {})
        if not isinstance(users, dict) or set(data) - {"users"}:
            raise ConfigError(f"{src}: expected only [users.NAME] tables")
        for name, entry in users.items():
            if not _NAME.match(name):
                raise ConfigError(f"{src}: users.{name}: a user name is 1-64 letters, digits or _.@-")
            if not isinstance(entry, dict) or set(entry) != {"role", "password"}:
                raise ConfigError(f"{src}: users.{name}: needs exactly the keys role and password")
            role = Role.parse(entry["role"], f"{src}: users.{name}.role")
            if not str(entry["password"]).startswith("scrypt$"):
                raise ConfigError(f"{src}: users.{name}.password: not an scrypt hash (write it with "
                                  "`loadarm user add`)")
            self._entries[name] = (role, str(entry["password"]))

    def __len__(self) -> int:
        return len(self._entries)

    def names(self) -> list[str]:
        """The user names, sorted."""
        return sorted(self._entries)

    def authenticate(self, name: str | None, password: str | None) -> User | None:
        """The user with this name and password, or None (unknown user or wrong password: the same answer).

        Parameters
        ----------
        name, password : str or None

        Returns
        -------
        User or None
        """
        entry = self._entries.get(name or "")
        if password is not None and len(password.encode()) > SECRET_BYTES:
            password = None                                   # refused unhashed (the same answer, the same time)
        if entry is None or password is None:
            verify_password(password or "", _dummy_hash())      # one scrypt, as for a known user
            return None
        return User(name, entry[0]) if verify_password(password, entry[1]) else None

    def role(self, name: str) -> Role | None:
        """A user's role (None: no such user)."""
        entry = self._entries.get(name)
        return None if entry is None else entry[0]

    def stamp(self, name: str) -> str | None:
        """What a user's entry is now (its role and password hash; None: no such user): a session opened under one
        stamp ends when it changes (the user removed, the password changed, the user added again)."""
        entry = self._entries.get(name)
        return None if entry is None else f"{entry[0].name}:{entry[1]}"

    def add(self, name: str, role: Role, password: str) -> None:
        """Add or replace a user and write the file (atomically, mode 0600).

        Parameters
        ----------
        name : str
        role : Role
        password : str
        """
        if not _NAME.match(name):
            raise ConfigError(f"user name {name!r}: 1-64 letters, digits or _.@-")
        self._entries[name] = (role, hash_password(password))
        self._write()

    def _known(self, name: str) -> tuple[Role, str]:
        entry = self._entries.get(name)
        if entry is None:
            raise ConfigError(f"{self.path}: no user {name!r} (users: {', '.join(self.names()) or 'none'})")
        return entry

    def remove(self, name: str) -> Role:
        """Remove a user and write the file; the role the user had.

        Raises
        ------
        ConfigError
            No such user (the users named).
        """
        role = self._known(name)[0]
        del self._entries[name]
        self._write()
        return role

    def set_password(self, name: str, password: str) -> Role:
        """Change a user's password (the role kept) and write the file; the user's role.

        Raises
        ------
        ConfigError
            No such user, or a password empty or too long.
        """
        role = self._known(name)[0]
        self._entries[name] = (role, hash_password(password))
        self._write()
        return role

    def _write(self) -> None:
        lines = ["# loadarm users: written by `loadarm user`; passwords are scrypt hashes", ""]
        for n in sorted(self._entries):
            r, h = self._entries[n]
            lines += [f"[users.{n!s}]", f'role = "{r.name.lower()}"', f'password = "{h}"', ""]

        atomic_write(self.path, "\n".join(lines), private=True)


class LiveUsers:
    """The users file as it is now, for a server that runs for hours: it is read again whenever it changes (its
    inode, size or modification time; ``loadarm user`` replaces it atomically), so a user removed or a password
    changed counts from the next request. A file made invalid by hand keeps the last valid users (a typo in the
    file must not log every operator out mid-transfer); a file removed means no users.

    Parameters
    ----------
    path : Path
        ``users.toml``.
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        self._lock = threading.Lock()
        self._key = self._file_key()
        self._users = Users(self.path)

    def _file_key(self):
        try:
            st = os.stat(self.path)
        except FileNotFoundError:
            return None
        return st.st_ino, st.st_size, st.st_mtime_ns

    def current(self) -> Users:
        """The users as the file has them now."""
        key = self._file_key()
        with self._lock:
            if key != self._key:
                try:
                    self._users, self._key = Users(self.path), key
                except ConfigError:
                    pass
            return self._users

    def __len__(self) -> int:
        return len(self.current())

    def names(self) -> list[str]:
        return self.current().names()

    def authenticate(self, name: str | None, password: str | None) -> User | None:
        """:meth:`Users.authenticate` on the file as it is now."""
        return self.current().authenticate(name, password)

    def stamp(self, name: str) -> str | None:
        """:meth:`Users.stamp` on the file as it is now."""
        return self.current().stamp(name)


#: The largest certificate file read, bytes (an X.509 certificate is one or two kilobytes; a chain a few).
CERTIFICATE_BYTES = 64 * 1024


def load_certificate(path: Path):
    """A certificate from a DER or PEM file: a regular file of at most :data:`CERTIFICATE_BYTES` (found: a 1 TiB
    sparse file raised MemoryError; a FIFO or a directory was "no such certificate file")."""
    from cryptography import x509

    data = read_binary(path, "certificate", limit=CERTIFICATE_BYTES)
    try:
        return x509.load_pem_x509_certificate(data) if data.lstrip().startswith(b"-----BEGIN") \
            else x509.load_der_x509_certificate(data)
    except ValueError as exc:
        raise ConfigError(f"{path}: not an X.509 certificate in DER or PEM ({exc})") from None


def client_certificate(folder: str | Path, name: str, app_uri: str) -> tuple[Path, Path]:
    """Make a self-signed OPC UA client certificate and key (``NAME.der``, ``NAME.pem`` mode 0600) in
    ``folder``: for a test client, or a script that talks to ``loadarm serve``.

    Parameters
    ----------
    folder : path
    name : str
        Common name and file stem.
    app_uri : str
        The client's application URI (it must match its ``application_uri``).

    Returns
    -------
    cert, key : Path
    """
    from asyncua.crypto import cert_gen
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization
    from cryptography.x509.oid import ExtendedKeyUsageOID

    key = cert_gen.generate_private_key()
    cert = cert_gen.generate_self_signed_app_certificate(
        key, name, {}, [x509.UniformResourceIdentifier(app_uri), x509.DNSName("localhost")],
        extended=[ExtendedKeyUsageOID.CLIENT_AUTH])
    folder = Path(folder)
    c = atomic_write(folder / f"{name}.der", cert.public_bytes(serialization.Encoding.DER))
    k = atomic_write(folder / f"{name}.pem", cert_gen.dump_private_key_as_pem(key), private=True)
    return c, k


def thumbprint(cert) -> str:
    """SHA-1 thumbprint of a certificate, hex (OPC UA's certificate identifier).

    Parameters
    ----------
    cert : cryptography.x509.Certificate

    Returns
    -------
    str
    """
    from cryptography.hazmat.primitives import serialization

    return hashlib.sha1(cert.public_bytes(serialization.Encoding.DER)).hexdigest()


def host_names(host: str = "localhost") -> list:
    """The subject alternative names of this host for a certificate it makes for itself: the endpoint's host, the
    host's name and fully qualified name (a client, and asyncua's own check, compare them: found, issue 29: every
    ``serve`` start warned "certificate does not contain the hostname in DNSNames vm"), ``localhost``, and the
    loopback addresses; an address as an IP address, a name as a DNS name.

    Parameters
    ----------
    host : str
        The endpoint's host.

    Returns
    -------
    list of cryptography.x509.GeneralName
    """
    import ipaddress
    import socket

    from cryptography import x509

    names, addresses = [], []
    for h in (host, socket.gethostname(), socket.getfqdn(), "localhost", "127.0.0.1", "::1"):
        try:
            ip = ipaddress.ip_address(h)
        except ValueError:
            if h and h not in names:
                names.append(h)
            continue
        if ip not in addresses:
            addresses.append(ip)
    return [*(x509.DNSName(n) for n in names), *(x509.IPAddress(a) for a in addresses)]


class StateDir:
    """The state directory of a plant-interface application (:mod:`loadarm.opcua.security`).

    Parameters
    ----------
    path : Path
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if self.path.exists() and not self.path.is_dir():
            raise ConfigError(f"--state-dir {self.path}: exists and is not a directory")

    @property
    def cert(self) -> Path:
        return self.path / "own" / "cert.der"

    @property
    def key(self) -> Path:
        return self.path / "own" / "key.pem"

    @property
    def trusted(self) -> Path:
        return self.path / "pki" / "trusted"

    @property
    def rejected(self) -> Path:
        return self.path / "pki" / "rejected"

    @property
    def users_file(self) -> Path:
        return self.path / "users.toml"

    def users(self) -> Users:
        """The users file (none yet: no users)."""
        return Users(self.users_file)

    def ensure(self, app_uri: str, host: str = "localhost", *, name: str = "loadarm") -> None:
        """Create the directories and, on first start, the application certificate and key (RSA 2048,
        SHA-256, valid five years, the application URI and the host's names (:func:`host_names`) in its subject
        alternative names). An existing key readable by anyone but its owner is refused.

        Parameters
        ----------
        app_uri : str
        host : str
        name : str
            Common name.

        Raises
        ------
        ConfigError
            A key with a too open mode, or a certificate that is not this application's.
        """
        for d in (self.cert.parent, self.trusted, self.rejected):
            d.mkdir(parents=True, exist_ok=True)
        os.chmod(self.cert.parent, 0o700)
        if self.key.exists():
            mode = stat.S_IMODE(self.key.stat().st_mode)
            if mode & 0o077:
                raise ConfigError(f"{self.key}: private key readable by others (mode {mode:04o}); "
                                  f"run `chmod 600 {self.key}`")
        if self.key.exists() and self.cert.exists():
            cert = load_certificate(self.cert)
            uris = _uris(cert)
            if app_uri not in uris:
                raise ConfigError(f"{self.cert}: certificate of another application ({', '.join(uris) or 'no URI'}, "
                                  f"expected {app_uri}); remove {self.cert.parent} to make a new one")
            return
        from asyncua.crypto import cert_gen
        from cryptography import x509
        from cryptography.hazmat.primitives import serialization
        from cryptography.x509.oid import ExtendedKeyUsageOID

        key = cert_gen.generate_private_key()
        cert = cert_gen.generate_self_signed_app_certificate(
            key, name, {"organizationName": "loadarm"}, [x509.UniformResourceIdentifier(app_uri), *host_names(host)],
            extended=[ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH], days=5 * 365)

        atomic_write(self.key, cert_gen.dump_private_key_as_pem(key), private=True)
        atomic_write(self.cert, cert.public_bytes(serialization.Encoding.DER))

    def trust(self, cert_file: str | Path) -> Path:
        """Copy a client certificate into the trust list (named by its thumbprint; DER).

        Parameters
        ----------
        cert_file : path

        Returns
        -------
        Path
            The trusted copy.
        """
        from cryptography.hazmat.primitives import serialization

        p = Path(cert_file)
        cert = load_certificate(p)
        self.trusted.mkdir(parents=True, exist_ok=True)
        out = self.trusted / f"{thumbprint(cert)}.der"
        atomic_write(out, cert.public_bytes(serialization.Encoding.DER))
        return out


def _uris(cert) -> list[str]:
    from cryptography import x509

    try:
        san = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName)
    except x509.ExtensionNotFound:
        return []
    return san.value.get_values_for_type(x509.UniformResourceIdentifier)


class LoginLimiter:
    """At most :data:`LOGIN_FAILURES` failed logins per user name and per client in :data:`LOGIN_WINDOW`:
    beyond that a login is refused before its password is checked (429), until the window has passed.

    A login takes its slot before its password is checked (:meth:`begin` counts it as failed, :meth:`succeeded`
    gives it back): concurrent wrong passwords cannot all pass the check while the first ones are being hashed
    (found: 40 at once all got 401, none 429)."""

    def __init__(self, *, clock: Callable[[], float] = time.monotonic, failures: int = LOGIN_FAILURES,
                 window: float = LOGIN_WINDOW):
        self.clock, self.failures, self.window = clock, failures, window
        self._fails: dict[str, list[float]] = {}
        self._lock = threading.Lock()

    #: Keys kept at most (user names and clients); past it, those with no failure in the window are dropped
    #: (an attacker spraying user names cannot grow the table without bound).
    MAX_KEYS = 10_000

    def _recent(self, key: str, now: float) -> list[float]:
        kept = [t for t in self._fails.get(key, ()) if now - t < self.window]
        self._fails[key] = kept
        return kept

    def blocked(self, user: str, client: str) -> float:
        """Seconds until a login for ``user`` from ``client`` may be tried again (0: now)."""
        now = self.clock()
        with self._lock:
            wait = 0.0
            for key in (f"user:{user}", f"client:{client}"):
                recent = self._recent(key, now)
                if len(recent) >= self.failures:
                    wait = max(wait, self.window - (now - recent[0]))
            return wait

    def begin(self, user: str, client: str) -> tuple[float, float]:
        """Take a login's slot before its password is checked.

        Returns
        -------
        wait : float
            Seconds until a login may be tried again; 0: go on, the slot is taken (counted as a failure until
            :meth:`succeeded`).
        ticket : float
            The slot's time, for :meth:`succeeded`.
        """
        now = self.clock()
        with self._lock:
            if len(self._fails) > self.MAX_KEYS:
                self._fails = {k: v for k, v in self._fails.items() if v and now - v[-1] < self.window}
            wait = 0.0
            keys = (f"user:{user}", f"client:{client}")
            for key in keys:
                recent = self._recent(key, now)
                if len(recent) >= self.failures:
                    wait = max(wait, self.window - (now - recent[0]))
            if wait > 0:
                return wait, now
            for key in keys:
                self._fails[key].append(now)
            return 0.0, now

    def failed(self, user: str, client: str) -> None:
        """Count a failed login that took no slot with :meth:`begin`."""
        now = self.clock()
        with self._lock:
            for key in (f"user:{user}", f"client:{client}"):
                self._recent(key, now).append(now)

    def succeeded(self, user: str, client: str | None = None, ticket: float | None = None) -> None:
        """A login succeeded: the user's failures are forgotten, and the client's slot of ``ticket`` given back."""
        with self._lock:
            self._fails.pop(f"user:{user}", None)
            slots = self._fails.get(f"client:{client}")
            if slots is not None and ticket in slots:
                slots.remove(ticket)
