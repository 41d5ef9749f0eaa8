"""Many records: in-process, a local process pool, or a Dask distributed cluster.

:func:`run_records` applies one job (``pipeline run`` passes
:func:`pipeline.run.process_record`) to every record spec and returns the results **in the
order of the specs**, whatever order they finish in. The job never raises for a bad record
(the failure travels in the result). If the job raises anyway, that record comes back
failed with the exception as its one-line reason (:func:`crashed`); if a pool worker dies
(the OOM killer), the records the broken pool had not finished are run again, each in a
worker of its own, and only one whose worker dies again fails (:func:`died`): the batch
always completes.

* ``workers == 1`` (or a single record): a plain loop in this process.
* ``workers > 1`` (default: one per core, at most one per record): a
  :class:`concurrent.futures.ProcessPoolExecutor` (:func:`local_pool`) whose workers start
  from a clean ``forkserver`` process (``spawn`` where there is none), never by forking
  this possibly threaded process; each worker limits the native BLAS/OpenMP pools to one
  thread (threadpoolctl, :func:`limit_native_threads`), as the in-process loop does, and
  dies with this process (:func:`pipeline.batch.interrupt.guard_worker`). An exception here
  (:class:`~pipeline.batch.interrupt.Interrupted` by SIGTERM or SIGINT included) cancels what is
  queued and terminates the workers. The specs and the config are small frozen, picklable
  values. A caller may pass its own pool (``pool=``) to use it again afterwards, e.g. for
  the report's plots (:func:`parallel_map`), instead of starting a second one.
* ``executor="dask"``: ``dask.distributed.Client(scheduler).map`` of the same job (the
  optional ``dask`` extra; the workers need ``pipeline`` importable). ``scheduler=None``
  starts a temporary local cluster, as ``Client()`` does. Paths in the specs must be
  absolute (:func:`pipeline.run.resolve_specs` makes them so): a worker runs elsewhere.

Progress (:mod:`pipeline.batch.progress`): a bar on stderr when ``progress`` is True, or when it
is None and stderr is a terminal; each record's time and outcome is logged at INFO on the
``pipeline`` logger (``pipeline run --verbose``).
"""

from __future__ import annotations

import collections
import contextlib
import logging
import multiprocessing
import os
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from typing import Any

from ..errors import UserError
from .interrupt import guard_worker, interruption, output_detached
from .jobs import Job, crashed, died, portable, record_fault, timed
from .progress import Tracker, show_progress

EXECUTORS = ("local", "dask")

log = logging.getLogger(__name__)


def run_records(specs: Sequence, cfg, job: Job, *, workers: int | None = None,
                executor: str = "local", scheduler: str | None = None,
                progress: bool | None = None, pool: ProcessPoolExecutor | None = None) -> list:
    """``[job(spec, cfg) for spec in specs]``, computed in parallel (module docstring).

    ``job`` must be a module-level function (it is pickled by name). Raises
    :class:`UserError` for a bad ``executor``, ``workers`` < 1, a missing Dask installation
    or an unreachable scheduler. ``pool``: a :func:`local_pool` to run in (``workers`` is
    then ignored).
    """
    check_executor(executor)
    specs = list(specs)
    if not specs:
        return []
    with Tracker(len(specs), show_progress(progress)) as tracker:
        if executor == "dask":
            from .cluster import run_dask

            return run_dask(specs, cfg, job, scheduler, tracker)
        if pool is not None:
            return _run_pool(specs, cfg, job, pool, tracker)
        with local_pool(workers, len(specs)) as own:
            if own is None:
                return _run_inline(specs, cfg, job, tracker)
            return _run_pool(specs, cfg, job, own, tracker)


def check_executor(executor: str) -> None:
    """A :class:`UserError` for an executor that is not one of :data:`EXECUTORS`."""
    if executor not in EXECUTORS:
        raise UserError(f"unknown executor {executor!r}; expected one of: "
                        + ", ".join(EXECUTORS))


def resolve_workers(workers: int | None, n_records: int) -> int:
    """Processes to use: ``workers`` (default: the cores), never more than the records."""
    if workers is not None and workers < 1:
        raise UserError(f"workers must be at least 1, got {workers}")
    wanted = workers if workers is not None else (os.cpu_count() or 1)
    return max(1, min(wanted, n_records))



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


def _worker_init(owner: int) -> None:
    """Pool worker start-up: die with ``owner``, one native thread for the worker's life."""
    guard_worker(owner)
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)
    from ..memory import reserve_blas_buffers

    reserve_blas_buffers()


# -- executors ---------------------------------------------------------------------------

def _run_inline(specs: list, cfg, job: Job, tracker: Tracker) -> list:
    out = []
    with limit_native_threads():
        for spec in specs:
            tracker.start(getattr(spec, "name", str(spec)))
            t0 = time.perf_counter()
            try:
                result = job(spec, cfg)
            except BaseException as exc:  # the job's contract is broken; the batch goes on
                stop = interruption(exc)  # a signal that came wrapped: not the record's
                if stop is not None:
                    raise stop from None
                if not record_fault(exc):
                    raise
                result = crashed(spec, exc)
            tracker.done(result, time.perf_counter() - t0)
            out.append(result)
    return out


def pool_context(draws: bool = False) -> multiprocessing.context.BaseContext:
    """``forkserver`` where available (Linux, macOS), else ``spawn``: no fork of a
    threaded parent.

    The fork server imports ``pipeline.run`` once (numpy, scipy, polars ... take seconds),
    and ``pipeline.report.build`` (matplotlib, another second) when the pool will
    ``draws`` the report's plots; every worker is forked from it with the modules loaded.
    The server lives as long as this process (its modules are those of its start). It and
    the resource tracker are started with stdout and stderr on /dev/null
    (:func:`pipeline.batch.interrupt.output_detached`): a helper must never hold the caller's
    pipes (``out=$(pipeline run ...)`` would hang).
    """
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(["pipeline.batch.forkserver_guard", "pipeline.run",
                                *(["pipeline.report.build"] if draws else [])])
    from multiprocessing import forkserver

    from .forkserver_guard import OWNER_ENV

    os.environ[OWNER_ENV] = str(os.getpid())  # the server's guard dies with this process
    with output_detached():
        forkserver.ensure_running()
    return ctx


@contextlib.contextmanager
def local_pool(workers: int | None, n_items: int,
               draws: bool = False) -> Iterator[ProcessPoolExecutor | None]:
    """A process pool of :func:`resolve_workers` workers, or None when that is one;
    ``draws``: it will also draw plots (:func:`pool_context`).

    Leaving the block normally waits for the pool; leaving it by an exception (an
    :class:`~pipeline.batch.interrupt.Interrupted` included) cancels the queued work and
    terminates the workers at once.
    """
    n = resolve_workers(workers, n_items)
    if n == 1:
        yield None
        return
    pool = ProcessPoolExecutor(max_workers=n, mp_context=pool_context(draws),
                               initializer=_worker_init, initargs=(os.getpid(),))
    try:
        yield pool
    except BaseException:
        terminate(pool)
        raise
    pool.shutdown(wait=True)


class LazyPool:
    """Worker processes for one record's fits (a :class:`pipeline.parallel.Workers`),
    started at the first :meth:`map`, so a short log that never spreads its fits never
    pays for them (the fork server's imports: about 1.5 s of CPU).

    :meth:`map` lets this process take queued chunks itself while the workers start, as
    :func:`_run_pool` does with records; if a worker dies (the OOM killer), the work goes
    on in this process: the same results, a warning on the log. Use it
    through :func:`lazy_pool`, which ends the workers.
    """

    def __init__(self, size: int):
        self.size = size
        self._pool: ProcessPoolExecutor | None = None
        self._broken = False

    def map(self, fn: Callable[[Any], Any], items: Sequence) -> list:
        items = list(items)
        if self._broken:  # a worker died earlier: the rest of the record runs here
            return [_portably((fn, x)) for x in items]
        if self._pool is None:
            self._pool = ProcessPoolExecutor(
                max_workers=self.size, mp_context=pool_context(), initializer=_worker_init,
                initargs=(os.getpid(),))
        try:
            out, self._broken = _steal_map(self._pool, self.size, _portably,
                                           [(fn, x) for x in items])
        except BaseException:  # a task raised: its siblings' work is of no use now
            self.close(cancel=True)
            raise
        return out

    def close(self, *, cancel: bool = False) -> None:
        """Wait for the workers to end (``cancel``: end them now)."""
        if self._pool is not None:
            terminate(self._pool) if cancel else self._pool.shutdown(wait=True)
            self._pool = None


@contextlib.contextmanager
def lazy_pool(workers: int | None) -> Iterator[LazyPool | None]:
    """A :class:`LazyPool` of ``workers`` processes (default: the cores), or None for one;
    leaving the block by an exception (SIGTERM's included) ends the workers at once."""
    n = resolve_workers(workers, os.cpu_count() or 1) if workers is None else workers
    if n < 1:
        raise UserError(f"workers must be at least 1, got {n}")
    if n == 1:
        yield None
        return
    pool = LazyPool(n)
    try:
        yield pool
    except BaseException:
        pool.close(cancel=True)
        raise
    pool.close()


def _steal_map(pool: ProcessPoolExecutor, size: int, fn: Callable[[Any], Any], items: list
               ) -> tuple[list, bool]:
    """``([fn(x) for x in items], broken)`` on ``pool`` (:func:`_drive`). When a worker
    dies (``broken``), what the pool had not returned is run here, and a warning says
    so."""
    out: list = [None] * len(items)

    def here(k: int) -> None:
        out[k] = fn(items[k])

    def done(k: int, fut: Future) -> bool:
        try:
            out[k] = fut.result()
        except BrokenProcessPool:
            return False
        return True

    in_flight, unsent = _drive(pool, size, len(items), lambda k: pool.submit(fn, items[k]),
                               here, done)
    lost = sorted(in_flight + unsent)
    if lost:
        log.warning("a worker process died; %d of %d parts of a record's fits are computed "
                    "in the main process instead", len(lost), len(items))
        for k in lost:
            here(k)
    return out, bool(lost)


def _drive(pool: ProcessPoolExecutor, size: int, n: int, send: Callable[[int], Future],
           here: Callable[[int], None], done: Callable[[int, Future], bool]
           ) -> tuple[list[int], list[int]]:
    """The scheduling both pools share. Items ``0..n-1`` are sent with ``send(k)``, at most
    ``size + 1`` in the pool at a time; while no worker has returned one (they are still
    starting), this process takes the last queued ones itself (``here(k)``); each item the
    pool finishes goes to ``done(k, future)``, which says False when the pool broke.
    Nothing is ever cancelled: Python 3.11's pool raises in its own thread (and leaves
    futures unset) when it breaks with a cancelled future in its books.

    Returns ``(in_flight, unsent)`` when the pool broke: the items it held (finished ones
    excepted) and the ones never sent; ``([], [])`` when every item was done."""
    queue = collections.deque(range(n))
    running: dict[Future, int] = {}
    returned = False
    while queue or running:
        try:
            while queue and len(running) <= size:
                running[send(queue[0])] = queue[0]
                queue.popleft()
        except BrokenProcessPool:
            return _salvaged(running, done), list(queue)
        if queue and not returned:
            here(queue.pop())
            returned = any(f.done() for f in running)
            continue
        finished, _ = wait(running, return_when=FIRST_COMPLETED)
        returned = True
        for fut in finished:
            k = running.pop(fut)
            if not done(k, fut):
                return [k, *_salvaged(running, done)], list(queue)
    return [], []


def _salvaged(running: dict[Future, int], done: Callable[[int, Future], bool]) -> list[int]:
    """After a break: the items of ``running`` that did not finish (those that did go to
    ``done``)."""
    lost = []
    for fut, k in running.items():
        if not (fut.done() and fut.exception() is None and done(k, fut)):
            lost.append(k)
    return lost


def terminate(pool: ProcessPoolExecutor) -> None:
    """Cancel the queued futures and end the workers now (SIGTERM, then SIGKILL).

    ``ProcessPoolExecutor`` has no public way to stop running work before Python 3.14
    (``terminate_workers``); its ``_processes`` map is the documented-in-source handle.
    """
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        with contextlib.suppress(Exception):
            p.terminate()
    deadline = time.monotonic() + 2.0
    for p in procs:
        with contextlib.suppress(Exception):
            p.join(max(0.0, deadline - time.monotonic()))
            if p.is_alive():
                p.kill()
                p.join(1.0)


def _run_pool(specs: list, cfg, job: Job, pool: ProcessPoolExecutor, tracker: Tracker) -> list:
    """Records in a process pool; the parent works too while the workers start.

    Starting the workers costs seconds (the fork server imports numpy, scipy, polars).
    Instead of waiting, the parent takes the last queued records itself, but only until a
    worker has finished its first record: from then on the parent would only compete with
    the workers for the cores. At most one record per worker (and one more) is in the
    pool at a time, so nothing is ever cancelled (Python 3.11's pool hangs when it breaks
    with a cancelled future in its books). Results are the same either way (pure
    per-record jobs).

    When a worker dies (the OOM killer), the pool breaks and every record in it fails
    with it: those (and one the broken pool refused to take) are run again, each in a
    worker of its own (:func:`_run_isolated`), so only a record that kills its worker
    again fails; the records not yet sent go to a fresh pool.
    """
    size = max(1, getattr(pool, "_max_workers", 1))
    out: list = [None] * len(specs)

    def here(i: int) -> None:
        out[i] = _run_inline([specs[i]], cfg, job, tracker)[0]

    def done(i: int, fut: Future) -> bool:
        try:
            out[i], seconds = fut.result()
        except BrokenProcessPool:
            return False
        except BaseException as exc:  # the job raised: its contract is broken
            if not record_fault(exc):
                raise
            out[i], seconds = crashed(specs[i], exc), None
        tracker.done(out[i], seconds)
        return True

    lost, queue = _drive(pool, size, len(specs),
                         lambda i: pool.submit(timed, job, specs[i], cfg), here, done)
    if lost:
        log.warning("a worker process died; the %d record(s) it took with it are run "
                    "again, each in a worker of its own", len(lost))
        _run_isolated(sorted(lost), specs, cfg, job, out, tracker, size)
    if queue:  # never sent (the pool broke): a fresh pool, as before the death
        rest = sorted(queue)
        fresh = ProcessPoolExecutor(max_workers=size, mp_context=pool_context(),
                                    initializer=_worker_init, initargs=(os.getpid(),))
        try:
            results = _run_pool([specs[i] for i in rest], cfg, job, fresh, tracker)
        except BaseException:
            terminate(fresh)
            raise
        fresh.shutdown(wait=True)
        for i, r in zip(rest, results, strict=True):
            out[i] = r
    return out


def _run_isolated(indices: list[int], specs: list, cfg, job: Job, out: list,
                  tracker: Tracker, size: int) -> None:
    """Each record of ``indices`` in a fresh one-worker pool (``size`` at a time), its
    result into ``out``: a record whose worker dies again fails alone (:func:`died`)."""
    ctx = pool_context()
    pending = collections.deque(indices)
    active: dict[Future, tuple[int, ProcessPoolExecutor]] = {}
    try:
        while pending or active:
            while pending and len(active) < size:
                i = pending.popleft()
                ex = ProcessPoolExecutor(max_workers=1, mp_context=ctx,
                                         initializer=_worker_init, initargs=(os.getpid(),))
                active[ex.submit(timed, job, specs[i], cfg)] = (i, ex)
            done, _ = wait(active, return_when=FIRST_COMPLETED)
            for fut in done:
                i, ex = active[fut]
                try:
                    out[i], seconds = fut.result()
                except BrokenProcessPool:
                    out[i], seconds = died(specs[i]), None
                except BaseException as exc:
                    if not record_fault(exc):
                        raise
                    out[i], seconds = crashed(specs[i], exc), None
                ex.shutdown(wait=True)
                del active[fut]
                tracker.done(out[i], seconds)
    except BaseException:
        for _, ex in active.values():
            terminate(ex)
        raise


def is_broken(pool: ProcessPoolExecutor) -> bool:
    """Whether a worker of ``pool`` died (it takes no more work). ``_broken`` is the
    executor's own flag (CPython 3.11-3.14); there is no public one."""
    return bool(getattr(pool, "_broken", False))


@contextlib.contextmanager
def parallel_map(pool: ProcessPoolExecutor | None, n_items: int, min_items: int = 8):
    """A ``map`` for pure, picklable per-record work (e.g. a record's report section):
    on ``pool`` (the batch's pool, used again) when there is one, it is whole and there
    are enough items, else the built-in ``map`` in this process. On the pool the items go
    out as :func:`_steal_map` sends them (nothing cancelled); if a worker dies meanwhile,
    the items it did not return are made here (a warning says so): a dead worker never
    costs the report."""
    if pool is None or n_items < min_items or is_broken(pool):
        yield map
        return
    n = max(1, getattr(pool, "_max_workers", 1))

    def robust(f, *its):
        return _steal_map(pool, n, _apply, [(f, args) for args in zip(*its, strict=True)])[0]
    yield robust


def _portably(task: tuple[Callable, Any]) -> Any:
    """``fn(x)`` for ``task = (fn, x)``, a native panic raised as :func:`portable` makes
    it (:class:`LazyPool`'s tasks, in a worker or here alike)."""
    fn, x = task
    try:
        return fn(x)
    except BaseException as exc:
        raise portable(exc) from None


def _apply(task: tuple[Callable, tuple]) -> Any:
    """``f(*args)`` for ``task = (f, args)`` (:func:`parallel_map`'s pool tasks)."""
    f, args = task
    return f(*args)
