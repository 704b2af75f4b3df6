"""``loadarm user add``: users of the plant interface."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from loadarm.cli.common import UserError, out
from loadarm.opcua.security import SECRET_BYTES, Role, StateDir

__all__ = ["app"]

app = typer.Typer(name="user", no_args_is_help=True, help="Users of the plant interface (STATE_DIR/users.toml).")


@app.command("add")
def user_add(
    name: Annotated[str, typer.Argument(help="User name (letters, digits, _.@-).")],
    role: Annotated[str, typer.Option("--role", help="viewer, operator or engineer.")],
    state_dir: Annotated[Path, typer.Option("--state-dir", help="The server's state directory.")] = Path("loadarm-state"),
    password_stdin: Annotated[bool, typer.Option("--password-stdin", help="Read the password from the first "
                                                                          "line of stdin.")] = False,
) -> None:
    """Add or replace a user (the password scrypt-hashed; the file mode 0600).

    Example: echo 'secret' | loadarm user add alice --role operator --password-stdin --state-dir out/state
    """

    r = Role.parse(role, "--role")
    if password_stdin:
        password = sys.stdin.readline(SECRET_BYTES + 2).rstrip("\n")     # bounded: never read a huge line
        if len(password.encode()) > SECRET_BYTES:
            raise UserError(f"--password-stdin: a password may have at most {SECRET_BYTES} bytes")
    else:
        import getpass

        password = getpass.getpass(f"password for {name}: ")
        if getpass.getpass("again: ") != password:
            raise UserError("the two passwords differ")
    st = StateDir(state_dir)
    st.users().add(name, r, password)
    out.print(f"user {name} ({r.name.lower()}) written to {st.users_file}")
