"""The Dask edge the campaigns and the operability study share: a client of a scheduler the user runs
(``--scheduler tcp://HOST:8786``). A wrong address, a scheduler that does not answer or refuses the connection
is one line naming the option and the address (:class:`loadarm.errors.ConfigError`), not Dask's own words alone.
"""

from __future__ import annotations

import os

from loadarm.errors import ConfigError

__all__ = ["connect_scheduler", "check_scheduler", "WORKERS_PER_CORE", "max_workers", "check_workers", "plan_workers"]


def connect_scheduler(address: str, *, timeout: float | None = None):
    """A ``distributed.Client`` of the scheduler at ``address``.

    Parameters
    ----------
    address : str
        ``tcp://host:port`` (or any address Dask takes).
    timeout : float, optional
        Seconds to wait for it (Dask's ``distributed.comm.timeouts.connect``, 30 s, by default).

    Returns
    -------
    distributed.Client

    Raises
    ------
    ConfigError
        The address is malformed, or nothing answers there in time.
    """
    import asyncio

    from distributed import Client

    wait = _wait(timeout)
    try:
        asyncio.run(_handshake(address, wait))
        return Client(address, timeout=wait)
    except (OSError, ValueError, TypeError) as exc:       # TimeoutError is an OSError
        _drop_failed_client()
        raise ConfigError(f"--scheduler {address}: no Dask scheduler reachable there ({exc})") from None


def check_scheduler(address: str, *, timeout: float | None = None) -> None:
    """That a Dask scheduler answers at ``address`` (its handshake, within ``timeout`` s), without a client.

    Parameters
    ----------
    address : str
        ``tcp://host:port``.
    timeout : float, optional
        Seconds (Dask's ``distributed.comm.timeouts.connect`` by default).

    Raises
    ------
    ConfigError
        The address is malformed, or nothing answers there in time.
    """
    import asyncio

    try:
        asyncio.run(_handshake(address, _wait(timeout)))
    except (OSError, ValueError, TypeError) as exc:
        raise ConfigError(f"--scheduler {address}: no Dask scheduler reachable there ({exc})") from None


def _wait(timeout: float | None) -> float:
    import dask
    import distributed  # noqa: F401  (registers its settings: distributed.comm.timeouts.connect)
    from dask.utils import parse_timedelta

    return parse_timedelta(dask.config.get("distributed.comm.timeouts.connect") if timeout is None else timeout,
                           default="seconds")


async def _handshake(address: str, wait: float) -> None:
    """Connect and exchange Dask's handshake within ``wait`` s: Dask's own connect timeout stops at the TCP
    connection (found: a bare listener that accepts and never answers hung ``campaign`` and ``operability`` past
    150 s in the handshake's read)."""
    import asyncio

    from distributed.comm import connect

    try:
        comm = await asyncio.wait_for(connect(address, timeout=wait), wait)
    except asyncio.TimeoutError:
        raise TimeoutError(f"no Dask handshake within {wait:g} s") from None
    await comm.close()


def _drop_failed_client() -> None:
    """Close the client a failed connection left behind as the process's default. Found (issue 26, in the test
    suite): ``Client("nonsense")`` raised but stayed the default client and set dask's scheduler to it, so the
    next dask computation in the same process (an xarray read) failed on the dead address."""
    from distributed import default_client

    try:
        client = default_client()
    except ValueError:                                     # no default client: nothing was left behind
        return
    if client.status != "running":
        client.close()


#: Worker processes allowed per core (more only share the cores: found, --workers 100000 forked 2073 processes).
WORKERS_PER_CORE = 4


def max_workers() -> int:
    """The most worker processes a study may start on this machine.

    Returns
    -------
    int
    """
    return WORKERS_PER_CORE * max(1, os.cpu_count() or 1)


def check_workers(option: str, workers: int | None) -> None:
    """Refuse a worker count that cannot run here, in one line.

    Parameters
    ----------
    option : str
        The option's name, for the message.
    workers : int or None
        None: the default (every core).

    Raises
    ------
    ConfigError
    """
    if workers is not None and not 1 <= workers <= max_workers():
        raise ConfigError(f"{option} must be in [1, {max_workers()}] ({WORKERS_PER_CORE} per core on "
                          f"{os.cpu_count() or 1} cores), got {workers}")


def plan_workers(workers: int | None, jobs: int) -> int:
    """The processes a study of ``jobs`` tasks starts: ``workers`` (default every core), no more than the jobs.

    Parameters
    ----------
    workers : int or None
    jobs : int

    Returns
    -------
    int

    Raises
    ------
    ConfigError
        ``workers`` out of :func:`check_workers`' range.
    """
    check_workers("--workers", workers)
    return max(1, min(jobs, (os.cpu_count() or 1) if workers is None else workers))
