"""The Dask client of a campaign: a local cluster, or a running scheduler whose address is checked first.

An address given by the user is checked before a :class:`dask.distributed.Client` is made for it, within
a bounded time (:data:`CONNECT_TIMEOUT_S`): its form (``tcp://HOST:PORT``), then a connection and one
request to which only a Dask scheduler gives the right answer. Whatever is at the address (nothing, a
refused port, a web server, a server that accepts and never answers, a worker), an unusable address
gives one :class:`~postcapture.core.errors.ScenarioError` naming ``--scheduler``, and no half-made
client is left to fail again when Python exits.
"""

from __future__ import annotations

import contextlib
import logging
import re
import threading

from postcapture.core.errors import MissingExtraError, Problem, ScenarioError

__all__ = ["CONNECT_TIMEOUT_S", "MAX_WORKERS", "check_scheduler", "dask_client"]

CONNECT_TIMEOUT_S = 5.0
"""Longest wait for a scheduler to answer (s)."""

MAX_WORKERS = 256
"""Most worker processes a local cluster may start."""

_EXPECTED = "the address of a running Dask scheduler, tcp://HOST:PORT"
_ADDRESS = re.compile(r"tcp://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+):([0-9]{1,5})", re.ASCII)


def _refuse(address: str, why: str) -> ScenarioError:
    return ScenarioError([Problem("--scheduler", _EXPECTED, f"{address!r} ({why})")])


def _identify(address: str, timeout: float) -> dict | None:
    """Connect and ask the server who it is; its answer, or None when there was none in time."""
    import asyncio

    from distributed.comm import connect

    async def ask():
        comm = await connect(address, timeout=timeout)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    answer: dict = {}

    def worker():
        try:
            answer["reply"] = asyncio.run(asyncio.wait_for(ask(), timeout))
        except BaseException as exc:  # any failure of the exchange means "not a scheduler"; its kind is the reason
            answer["error"] = exc

    thread = threading.Thread(target=worker, name="scheduler-probe", daemon=True)
    thread.start()
    thread.join(timeout + 1.0)  # the thread is bounded by its own wait_for; this is a second guard
    if thread.is_alive() or isinstance(answer.get("error"), (TimeoutError, asyncio.TimeoutError)):
        return None
    if "error" in answer:
        exc = answer["error"]
        raise _refuse(address, f"no Dask scheduler answers there: {type(exc).__name__}: {exc}".rstrip(": "))
    return answer.get("reply")


def check_scheduler(address, timeout: float = CONNECT_TIMEOUT_S) -> str:
    """Check that a Dask scheduler answers at ``address``; return the address.

    Raises
    ------
    ScenarioError
        Naming ``--scheduler``: for an address not of the form ``tcp://HOST:PORT`` (port 1-65535), or where
        no Dask scheduler answers within ``timeout`` seconds.
    MissingExtraError
        When Dask is not installed.
    """
    if not isinstance(address, str) or not _ADDRESS.fullmatch(address):
        raise _refuse(str(address), "not of the form tcp://HOST:PORT; tls, ws and inproc addresses are not supported")
    port = int(_ADDRESS.fullmatch(address).group(2))
    if not 1 <= port <= 65535:
        raise _refuse(address, f"port {port} outside 1-65535")
    try:
        import distributed  # noqa: F401
    except ImportError as exc:
        raise MissingExtraError("dask[distributed]", "campaign") from exc
    reply = _identify(address, timeout)
    if reply is None:
        raise _refuse(address, f"no answer within {timeout:g} s")
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        kind = reply.get("type") if isinstance(reply, dict) else type(reply).__name__
        raise _refuse(address, f"the server there is not a Dask scheduler (it says {kind!r})")
    return address


@contextlib.contextmanager
def dask_client(scheduler: str | None, workers: int):
    """A client on ``scheduler`` (checked with :func:`check_scheduler`), or on a local cluster of ``workers``
    single-threaded worker processes on 127.0.0.1 (they leave Ctrl-C to this process)."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:
        raise MissingExtraError("dask[distributed]", "campaign") from exc
    # Dask logs every start and stop of its workers and servers at INFO: keep a campaign's output to itself.
    quiet = logging.getLogger("distributed")
    level = quiet.level
    quiet.setLevel(logging.ERROR)
    cluster = None
    try:
        if scheduler is None:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=":0", silence_logs=logging.ERROR,
                                   preload=["postcapture.studies.pool"])  # workers leave Ctrl-C to us
            client = Client(cluster, set_as_default=False)
        else:
            check_scheduler(scheduler)
            try:
                client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S:g}s", set_as_default=False)
            except (OSError, TimeoutError, ValueError) as exc:  # it answered the check, then went away
                raise _refuse(scheduler, f"{type(exc).__name__}: {exc}") from None
        try:
            yield client
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    except BaseException:
        # interrupted or failed: the cluster's nannies may still be closing (their INFO lines would follow
        # the one-line message the user is given), so the distributed logger stays quiet
        raise
    else:
        quiet.setLevel(level)
