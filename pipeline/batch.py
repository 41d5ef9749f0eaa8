"""Many records: in-process, a local process pool, or a Dask distributed cluster.

:func:`run_records` applies one job (``pipeline run`` passes
:func:`pipeline.run.process_record`) to every record spec and returns the results **in the
order of the specs**, whatever order they finish in. The job never raises for a bad record
(the failure travels in the result). If the job raises anyway, that record comes back
failed with the exception as its one-line reason (:func:`crashed`); if a pool worker dies,
the pool is broken and the records not finished by then come back failed the same way: the
batch always completes.

* ``workers == 1`` (or a single record): a plain loop in this process.
* ``workers > 1`` (default: one per core, at most one per record): a
  :class:`concurrent.futures.ProcessPoolExecutor` whose workers start from a clean
  ``forkserver`` process (``spawn`` where there is none), never by forking this possibly
  threaded process; each worker limits the native BLAS/OpenMP pools to one thread
  (threadpoolctl, :func:`limit_native_threads`), as the in-process loop does.
  The specs and the config are small frozen, picklable values.
* ``executor="dask"``: ``dask.distributed.Client(scheduler).map`` of the same job (the
  optional ``dask`` extra; the workers need ``pipeline`` installed). ``scheduler=None``
  starts a temporary local cluster, as ``Client()`` does.

A rich progress bar (records done, failures, elapsed time, ETA) is drawn on stderr when
``progress`` is True, or when it is None and stdout is a terminal.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from contextlib import AbstractContextManager, contextmanager
from typing import Any

from .errors import UserError
from .results import RecordResult

EXECUTORS = ("local", "dask")
DASK_HINT = "install the dask extra: pip install .[dask]"

Job = Callable[[Any, Any], Any]


def run_records(specs: Sequence, cfg, job: Job, *, workers: int | None = None,
                executor: str = "local", scheduler: str | None = None,
                progress: bool | None = None) -> list:
    """``[job(spec, cfg) for spec in specs]``, computed in parallel (module docstring).

    ``job`` must be a module-level function (it is pickled by name). Raises
    :class:`UserError` for a bad ``executor``, ``workers`` < 1, a missing Dask installation
    or an unreachable scheduler.
    """
    if executor not in EXECUTORS:
        raise UserError(f"unknown executor {executor!r}; expected one of: "
                        + ", ".join(EXECUTORS))
    specs = list(specs)
    if not specs:
        return []
    show = sys.stdout.isatty() if progress is None else progress
    with Tracker(len(specs), show) as tracker:
        if executor == "dask":
            return _run_dask(specs, cfg, job, scheduler, tracker)
        n = resolve_workers(workers, len(specs))
        if n == 1:
            return _run_inline(specs, cfg, job, tracker)
        return _run_pool(specs, cfg, job, n, tracker)


def resolve_workers(workers: int | None, n_records: int) -> int:
    """Processes to use: ``workers`` (default: the cores), never more than the records."""
    if workers is not None and workers < 1:
        raise UserError(f"workers must be at least 1, got {workers}")
    wanted = workers if workers is not None else (os.cpu_count() or 1)
    return max(1, min(wanted, n_records))


def crashed(spec, exc: BaseException) -> RecordResult:
    """The failed result of a record whose job raised or whose worker died."""
    where = getattr(spec, "path", None) or getattr(spec, "name", None) or str(spec)
    reason = " ".join(f"{where}: processing crashed ({type(exc).__name__}: {exc})".split())
    return RecordResult(name=getattr(spec, "name", str(spec)), source=str(where), error=reason)


def is_failure(result) -> bool:
    """True for a failed record result."""
    return not getattr(result, "ok", True)


@contextmanager
def limit_native_threads() -> Iterator[None]:
    """One BLAS/OpenMP thread while the block runs (threadpoolctl).

    Many tiny least-squares problems: native thread pools cost more than they save
    (measured: a single process ran 2.7x slower with OpenBLAS threads on 2 cores,
    BENCHMARKS.md) and N pool workers each with a pool oversubscribe the cores.
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        yield


def _worker_init() -> None:
    """Pool worker start-up: one native thread for the worker's life."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)


# -- executors ---------------------------------------------------------------------------

def _run_inline(specs: list, cfg, job: Job, tracker: Tracker) -> list:
    out = []
    with limit_native_threads():
        for spec in specs:
            try:
                result = job(spec, cfg)
            except Exception as exc:  # the job's contract is broken; keep the batch going
                result = crashed(spec, exc)
            tracker.done(result)
            out.append(result)
    return out


def pool_context() -> multiprocessing.context.BaseContext:
    """``forkserver`` where available (Linux, macOS), else ``spawn``: no fork of a
    threaded parent.

    The fork server imports ``pipeline.run`` once (numpy, scipy, polars ... take seconds)
    and every worker is forked from it with the modules loaded; the server lives as long
    as this process, so later pools start at once.
    """
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(["pipeline.run", "pipeline.report.build"])
    return ctx


def _run_pool(specs: list, cfg, job: Job, n: int, tracker: Tracker) -> list:
    """Records in a process pool; the parent works too, from the back of the queue.

    Starting the workers costs seconds (the fork server imports numpy, scipy, polars).
    Instead of waiting, the parent takes the last queued records itself: a future that is
    still pending can be cancelled and run here; it stops when it meets a record the
    pool has already claimed. Results are the same either way (pure per-record jobs).
    """
    out: list = [None] * len(specs)
    with ProcessPoolExecutor(max_workers=n, mp_context=pool_context(),
                             initializer=_worker_init) as pool:
        futures: dict[Future, int] = {pool.submit(job, spec, cfg): i
                                      for i, spec in enumerate(specs)}
        stolen = set()
        for fut in reversed(list(futures)):
            if not fut.cancel():
                break
            i = futures[fut]
            stolen.add(fut)
            out[i] = _run_inline([specs[i]], cfg, job, tracker)[0]
        for fut in as_completed([f for f in futures if f not in stolen]):
            i = futures[fut]
            try:
                out[i] = fut.result()
            except Exception as exc:  # a worker died (BrokenProcessPool) or the job raised
                out[i] = crashed(specs[i], exc)
            tracker.done(out[i])
    return out


@contextlib.contextmanager
def parallel_map(workers: int | None, n_items: int, min_items: int = 8):
    """A ``map`` for pure, picklable per-record work (e.g. a record's report section):
    a local process pool's ``map`` when there are workers and enough items, else ``map``."""
    n = resolve_workers(workers, n_items)
    if n == 1 or n_items < min_items:
        yield map
        return
    with ProcessPoolExecutor(max_workers=n, mp_context=pool_context(),
                             initializer=_worker_init) as pool:
        yield lambda f, *its: pool.map(f, *its, chunksize=max(1, n_items // (4 * n)))


def _run_dask(specs: list, cfg, job: Job, scheduler: str | None, tracker: Tracker) -> list:
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:
        raise UserError(f"the dask executor needs dask.distributed; {DASK_HINT}") from None
    try:
        client = Client(scheduler, timeout="20s") if scheduler else Client()
    except (OSError, TimeoutError, ValueError) as exc:
        raise UserError(f"cannot reach the Dask scheduler at {scheduler}: "
                        f"{type(exc).__name__}: {exc}") from None
    with client:
        cfg_future = client.scatter(cfg, broadcast=True)
        futures = client.map(job, specs, cfg=cfg_future, pure=False)
        index = {fut.key: i for i, fut in enumerate(futures)}
        out: list = [None] * len(specs)
        for fut in dask_completed(futures):
            i = index[fut.key]
            try:
                out[i] = fut.result()
            except Exception as exc:  # the job raised on the worker, or the worker died
                out[i] = crashed(specs[i], exc)
            tracker.done(out[i])
            fut.release()
        return out


# -- progress ----------------------------------------------------------------------------

class Tracker(AbstractContextManager):
    """Counts finished records and failures; draws a rich progress bar when ``show``."""

    def __init__(self, total: int, show: bool) -> None:
        self.total = total
        self.show = show
        self.completed = 0
        self.failures = 0
        self._progress = None
        self._task = None

    def __enter__(self) -> Tracker:
        if self.show:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            self._progress = Progress(
                TextColumn("[bold]records"), BarColumn(), MofNCompleteColumn(),
                TextColumn("failures: {task.fields[failures]}"), TimeElapsedColumn(),
                TextColumn("ETA"), TimeRemainingColumn(),
                console=Console(stderr=True), transient=False,
            )
            self._progress.start()
            self._task = self._progress.add_task("records", total=self.total, failures=0)
        return self

    def done(self, result) -> None:
        self.completed += 1
        self.failures += int(is_failure(result))
        if self._progress is not None:
            self._progress.update(self._task, advance=1, failures=self.failures)

    def __exit__(self, *exc) -> None:
        if self._progress is not None:
            self._progress.stop()
        return None
