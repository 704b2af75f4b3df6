"""``loadarm user add | list | remove | passwd``: users of the plant interface. Each change is logged to the event
log (kind ``security``, with who made it), and counts at once: a running screen reads the users file as it is now
and ends a removed user's sessions (or a user's whose password changed) at their next request."""

from __future__ import annotations

import getpass
import os
import socket
import sys
from pathlib import Path
from typing import Annotated

import typer

from loadarm.cli.common import JsonOpt, Table, UserError, check_outputs, out, print_json
from loadarm.eventlog import EventLog
from loadarm.opcua.security import SECRET_BYTES, Role, StateDir
from loadarm.vocab import EVENTS

__all__ = ["app"]

app = typer.Typer(name="user", no_args_is_help=True, help="Users of the plant interface (STATE_DIR/users.toml); "
                                                          "each change logged to the event log.")

#: The event log's run that holds every change of the users (``loadarm log --run users``); each event's wall
#: time says when.
AUDIT_RUN = "users"

StateDirOpt = Annotated[Path, typer.Option("--state-dir", help="The server's state directory.")]
NameArg = Annotated[str, typer.Argument(help="User name (letters, digits, _.@-).")]
PasswordStdinOpt = Annotated[bool, typer.Option("--password-stdin", help="Read the password from the first line of "
                                                                         "stdin.")]
DbOpt = Annotated[Path, typer.Option("--db", help="SQLite event log the change is logged to (serve's).")]


def _password(name: str, from_stdin: bool) -> str:
    if from_stdin:
        password = sys.stdin.readline(SECRET_BYTES + 2).rstrip("\n")     # bounded: never read a huge line
        if len(password.encode()) > SECRET_BYTES:
            raise UserError(f"--password-stdin: a password may have at most {SECRET_BYTES} bytes")
        return password
    password = getpass.getpass(f"password for {name}: ")
    if getpass.getpass("again: ") != password:
        raise UserError("the two passwords differ")
    return password


def _operator() -> str:
    """Who made the change: the login name on this host."""
    try:
        who = getpass.getuser()
    except (KeyError, OSError):
        who = str(os.getuid()) if hasattr(os, "getuid") else "?"
    return f"{who}@{socket.gethostname()}"


class _Audit:
    """The event log a change goes to, opened before the change (a log that cannot be written refuses the
    command before the users file is touched)."""

    def __init__(self, db: Path, st: StateDir):
        check_outputs({"--db": db}, [st.users_file], appended=("--db",))
        self.log, self.st = EventLog(db, run=AUDIT_RUN), st

    def __enter__(self) -> "_Audit":
        return self

    def __exit__(self, *exc) -> None:
        self.log.close()

    def note(self, code: str, name: str, role: Role) -> None:
        self.log.append(0.0, "-", "security", f"{EVENTS[code].label}: {name} ({role.name.lower()})", code=code,
                        user=name, role=role.name.lower(), by=_operator(), users_file=str(self.st.users_file))


@app.command("add")
def user_add(
    name: NameArg,
    role: Annotated[str, typer.Option("--role", help="viewer, operator or engineer.")],
    state_dir: StateDirOpt = Path("loadarm-state"),
    password_stdin: PasswordStdinOpt = False,
    db: DbOpt = Path("loadarm-events.db"),
) -> None:
    """Add or replace a user (the password scrypt-hashed; the file mode 0600). A replaced user's open sessions on
    the screen end.

    Example: echo 'secret' | loadarm user add alice --role operator --password-stdin --state-dir out/state
    """

    r = Role.parse(role, "--role")
    password = _password(name, password_stdin)
    st = StateDir(state_dir)
    with _Audit(db, st) as audit:
        st.users().add(name, r, password)
        audit.note("security.user_added", name, r)
    out.print(f"user {name} ({r.name.lower()}) written to {st.users_file}; logged to {db}")


@app.command("list")
def user_list(state_dir: StateDirOpt = Path("loadarm-state"), as_json: JsonOpt = False) -> None:
    """List the users and their roles (never a password or its hash).

    Example: loadarm user list --state-dir out/state
    """

    st = StateDir(state_dir)
    users = st.users()
    rows = [{"user": n, "role": users.role(n).name.lower()} for n in users.names()]
    if as_json:
        print_json(rows)
        return
    out.print(f"{st.users_file}: {len(rows)} user{'' if len(rows) == 1 else 's'}")
    if rows:
        t = Table()
        t.add_column("user", no_wrap=True)
        t.add_column("role")
        for r in rows:
            t.add_row(r["user"], r["role"])
        out.print(t)


@app.command("remove")
def user_remove(name: NameArg, state_dir: StateDirOpt = Path("loadarm-state"),
                db: DbOpt = Path("loadarm-events.db")) -> None:
    """Remove a user: a running screen refuses the user's session at its next request (and the next login).

    Example: loadarm user remove alice --state-dir out/state
    """

    st = StateDir(state_dir)
    users = st.users()
    if users.role(name) is None:
        raise UserError(f"no user {name!r} in {st.users_file} (users: {', '.join(users.names()) or 'none'})")
    with _Audit(db, st) as audit:
        role = users.remove(name)
        audit.note("security.user_removed", name, role)
    out.print(f"user {name} ({role.name.lower()}) removed from {st.users_file}; logged to {db}")


@app.command("passwd")
def user_passwd(name: NameArg, state_dir: StateDirOpt = Path("loadarm-state"), password_stdin: PasswordStdinOpt = False,
                db: DbOpt = Path("loadarm-events.db")) -> None:
    """Change a user's password (the role kept): the user's open sessions on the screen end.

    Example: echo 'new-secret' | loadarm user passwd alice --password-stdin --state-dir out/state
    """

    st = StateDir(state_dir)
    users = st.users()
    if users.role(name) is None:
        raise UserError(f"no user {name!r} in {st.users_file} (users: {', '.join(users.names()) or 'none'})")
    password = _password(name, password_stdin)
    with _Audit(db, st) as audit:
        role = users.set_password(name, password)
        audit.note("security.password_changed", name, role)
    out.print(f"password of {name} ({role.name.lower()}) changed in {st.users_file}; logged to {db}")
