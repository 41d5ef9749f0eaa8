"""Clean shutdown: SIGTERM and SIGINT become an exception, and pool workers die with us.

* :func:`handle_signals` (the CLI wraps a command in it): SIGTERM and SIGINT raise
  :class:`Interrupted` in the main thread, so ``finally`` blocks run (the batch layer
  terminates its workers, the report writer removes its temporary folder) and the command
  exits with the conventional code 128 + signal (130 for SIGINT, 143 for SIGTERM).
* :func:`deferred`: a signal that arrives inside the block is held until the block ends,
  for the few renames that must not be cut in half (replacing a previous report).
* :func:`guard_worker`: run in every pool worker at start-up. A worker must not outlive
  the process that started it, however that one ends (SIGKILL included): otherwise it
  blocks forever on its task queue (it holds that queue's write end itself, so it never
  sees end-of-file), keeps the fork server and the resource tracker alive with it, and
  all of them hold the caller's stdout and stderr, so ``out=$(pipeline run ...)`` hangs.
  On Linux the kernel signals the worker when its parent (the fork server) dies
  (``prctl(PR_SET_PDEATHSIG)``, prctl(2)); everywhere, a daemon thread polls the owner's
  pid and ends the worker when the owner is gone, which also ends the fork server (its
  "alive" pipe reaches end-of-file once the owner and the workers are gone) and then the
  resource tracker (the same for its pipe).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator

#: Signals that end a run cleanly.
SIGNALS = (signal.SIGTERM, signal.SIGINT)
#: How often a worker checks that its owner is alive (s).
WATCH_INTERVAL = 0.25


class Interrupted(BaseException):
    """The run was asked to stop (SIGTERM, SIGINT). A BaseException, like
    KeyboardInterrupt, so that no ``except Exception`` of a job swallows it."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum

    @property
    def name(self) -> str:
        return signal.Signals(self.signum).name

    @property
    def exit_code(self) -> int:
        """128 + the signal number, as a shell reports a process ended by it."""
        return 128 + self.signum


_state = threading.local()


def _raise(signum: int, _frame) -> None:
    held = getattr(_state, "held", None)
    if held is not None:  # inside deferred(): raise when the block ends
        held.append(signum)
        return
    raise Interrupted(signum)


@contextlib.contextmanager
def handle_signals() -> Iterator[None]:
    """SIGTERM and SIGINT raise :class:`Interrupted` while the block runs (main thread
    only; elsewhere this does nothing). The previous handlers come back afterwards."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, _raise) for s in SIGNALS}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def interruption(exc: BaseException | None) -> Interrupted | None:
    """The :class:`Interrupted` behind ``exc``, if any: a signal that arrives inside an
    import or a descriptor's ``__set_name__`` reaches us wrapped (``RuntimeError: Error
    calling __set_name__ ...``), with the Interrupted as its cause or context."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, Interrupted):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Hold SIGTERM/SIGINT (when :func:`handle_signals` is active) until the block ends,
    then raise :class:`Interrupted` for the first one held."""
    outer = getattr(_state, "held", None)
    if outer is not None:  # nested: the outer block decides
        yield
        return
    _state.held = []
    try:
        yield
    finally:
        held, _state.held = _state.held, None
    if held:
        raise Interrupted(held[0])


# -- pool workers ------------------------------------------------------------------------

PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def die_with_parent(sig: int = signal.SIGKILL) -> None:
    """Linux: the kernel sends ``sig`` to this process when its parent ends (prctl(2)
    PR_SET_PDEATHSIG); elsewhere nothing."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, sig, 0, 0, 0)


def guard_worker(owner: int) -> None:
    """Make this pool worker die with ``owner`` (the pid of the process running the batch).

    Also ignores SIGINT: a Ctrl-C reaches the whole process group, and the owner, not
    each worker, decides how the batch stops (it terminates the workers).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent()
    parent = os.getppid()
    if not _alive(owner) or os.getppid() != parent:
        os._exit(1)  # the owner died before the guard was set
    threading.Thread(target=_watch, args=(owner, parent), daemon=True,
                     name="pipeline-owner-watch").start()


def _watch(owner: int, parent: int) -> None:
    while _alive(owner) and os.getppid() == parent:
        time.sleep(WATCH_INTERVAL)
    os._exit(1)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # a pid reused by another user's process: ours is gone
        return False
    return True


@contextlib.contextmanager
def output_detached() -> Iterator[None]:
    """File descriptors 1 and 2 are /dev/null while the block runs, so helper processes
    started in it (the fork server, the resource tracker, and the pool workers forked
    from the server) never hold the caller's stdout and stderr. A worker's failures still
    reach the user: a job's exception travels back to this process with its result."""
    try:
        sys.stdout.flush()
        sys.stderr.flush()
        saved = [os.dup(1), os.dup(2)]
    except (OSError, ValueError, AttributeError):  # no real descriptors
        yield
        return
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        yield
    finally:
        for fd, copy in zip((1, 2), saved, strict=True):
            os.dup2(copy, fd)
            os.close(copy)
        os.close(null)
