"""What a batch job gives back and how its failures read: a record's result and time from
a worker (:func:`timed`), the failed result of a job that raised (:func:`crashed`) or
whose worker died twice (:func:`died`), and which exceptions are a record's own fault
(:func:`record_fault`). Shared by the local pool (:mod:`.pool`) and Dask (:mod:`.cluster`)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from ..results import RecordResult

Job = Callable[[Any, Any], Any]


def crashed(spec, exc: BaseException) -> RecordResult:
    """The failed result of a record whose job raised or whose worker died."""
    where = getattr(spec, "path", None) or getattr(spec, "name", None) or str(spec)
    reason = " ".join(f"{where}: processing crashed ({type(exc).__name__}: {exc})".split())
    return RecordResult(name=getattr(spec, "name", str(spec)), source=str(where), error=reason)


def timed(job: Job, spec, cfg) -> tuple[Any, float]:
    """``(job(spec, cfg), seconds)``: what a worker sends back (module-level: picklable).
    A native panic is sent as a RuntimeError (:func:`portable`)."""
    t0 = time.perf_counter()
    try:
        return job(spec, cfg), time.perf_counter() - t0
    except BaseException as exc:
        raise portable(exc) from None


def portable(exc: BaseException) -> BaseException:
    """``exc``, or for a native library's panic (pyo3's ``PanicException``, which cannot be
    pickled: the parent would get a PicklingError instead) a RuntimeError saying it."""
    if type(exc).__name__ == "PanicException":
        return RuntimeError(f"PanicException: {exc}")
    return exc


def record_fault(exc: BaseException) -> bool:
    """Whether a job's exception is its record's fault (the record fails, the batch goes
    on): any Exception, and a native library's panic (pyo3's ``PanicException``, a
    BaseException); not KeyboardInterrupt, SystemExit or an interruption."""
    return isinstance(exc, Exception) or type(exc).__name__ == "PanicException"


def died(spec) -> RecordResult:
    """The failed result of a record whose worker process died, twice: the second time
    in a worker of its own."""
    where = getattr(spec, "path", None) or getattr(spec, "name", None) or str(spec)
    return RecordResult(name=getattr(spec, "name", str(spec)), source=str(where), error=(
        f"{where}: its worker process died while processing it, in the shared pool and "
        "again in a worker of its own (killed by the system: out of memory?); the other "
        "records went on"))
