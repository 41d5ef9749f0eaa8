"""The Dask executor of :func:`pipeline.batch.pool.run_records`: the same job mapped over a
``dask.distributed`` cluster (the optional ``dask`` extra), its scheduler reached within
bounded time (:func:`probe_scheduler`, :func:`connect`)."""

from __future__ import annotations

import socket
import threading

from ..errors import UserError
from .jobs import Job, crashed, record_fault, timed
from .progress import Tracker

DASK_HINT = "install the dask extra: pip install .[dask]"


def probe_scheduler(address: str, timeout: float = 5.0) -> None:
    """A :class:`UserError` at once for a ``tcp://HOST:PORT`` address that is malformed or
    refuses connections (``Client`` would retry for its whole timeout); other schemes are
    left to Dask."""
    from urllib.parse import urlsplit

    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    if parts.scheme != "tcp":
        return
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host = port = None
    if not host or port is None:
        raise UserError(f"--scheduler {address!r}: expected a Dask scheduler address like "
                        "tcp://HOST:PORT")
    try:
        socket.create_connection((host, port), timeout=timeout).close()
    except OSError as exc:
        raise UserError(f"cannot reach the Dask scheduler at {address}: "
                        f"{exc.strerror or exc}") from None


#: Seconds a scheduler has to answer once it has accepted the connection.
CONNECT_TIMEOUT = 20.0


def connect(client_type, scheduler: str, timeout: float = CONNECT_TIMEOUT):
    """``Client(scheduler)``, or a :class:`UserError` within ``timeout`` seconds (and a
    few more): a port that accepts connections and never answers (or answers HTTP) kept
    ``Client(..., timeout="20s")`` waiting for ever (issue 31: still running at 100 s).
    The attempt runs in a daemon thread; one that never returns is left behind, and the
    command ends with its error."""
    box: dict = {}

    def connect() -> None:
        try:
            box["client"] = client_type(scheduler, timeout=f"{timeout:g}s")
        except BaseException as exc:  # MemoryError too: a peer's bytes read as a length
            box["error"] = exc

    thread = threading.Thread(target=connect, name="dask-connect", daemon=True)
    thread.start()
    thread.join(timeout + min(5.0, timeout))  # Client's own timeout first, if it keeps it
    if thread.is_alive():
        raise UserError(f"cannot reach the Dask scheduler at {scheduler}: the port accepted "
                        f"the connection but nothing answered as a Dask scheduler within "
                        f"{timeout:g} s; check the address: it is the tcp://HOST:PORT "
                        "`dask scheduler` prints")
    if "error" in box:
        exc = box["error"]
        if not isinstance(exc, Exception):
            raise exc
        raise UserError(" ".join(f"cannot reach the Dask scheduler at {scheduler}: "
                                 f"{type(exc).__name__}: {exc}".split())[:300]) from None
    return box["client"]


def run_dask(specs: list, cfg, job: Job, scheduler: str | None, tracker: Tracker) -> list:
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:
        raise UserError(f"the dask executor needs dask.distributed; {DASK_HINT}") from None
    if scheduler:
        probe_scheduler(scheduler)
        client = connect(Client, scheduler)
    else:
        client = Client()
    with client:
        cfg_future = client.scatter(cfg, broadcast=True)
        futures = client.map(timed, [job] * len(specs), specs, cfg=cfg_future, pure=False)
        index = {fut.key: i for i, fut in enumerate(futures)}
        out: list = [None] * len(specs)
        for fut in dask_completed(futures):
            i = index[fut.key]
            try:
                out[i], seconds = fut.result()
            except BaseException as exc:  # the job raised on the worker, or it died
                if not record_fault(exc):
                    raise
                out[i], seconds = crashed(specs[i], exc), None
            tracker.done(out[i], seconds)
            fut.release()
        return out
