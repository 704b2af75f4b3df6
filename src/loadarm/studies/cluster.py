"""The Dask edge the campaigns and the operability study share: a client of a scheduler the user runs
(``--scheduler tcp://HOST:8786``). A wrong address, a scheduler that does not answer or refuses the connection
is one line naming the option and the address (:class:`loadarm.errors.ConfigError`), not Dask's own words alone.
"""

from __future__ import annotations

from loadarm.errors import ConfigError

__all__ = ["connect_scheduler"]


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
    from distributed import Client

    try:
        return Client(address) if timeout is None else Client(address, timeout=timeout)
    except (OSError, ValueError, TypeError) as exc:       # TimeoutError is an OSError
        _drop_failed_client()
        raise ConfigError(f"--scheduler {address}: no Dask scheduler reachable there ({exc})") from None


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
