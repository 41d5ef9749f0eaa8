"""``python -m pipeline`` and the ``pipeline`` command: the command line, in a process that
is the command's own, so polars' allocator is set up first (:func:`pipeline.memory.
polars_returns_freed_pages`, before anything imports polars; pool workers inherit it), and
glibc's mmap threshold fixed (:func:`pipeline.memory.large_arrays_mapped`), its arenas
few (:func:`pipeline.memory.few_malloc_arenas`), and one
native BLAS thread (:func:`pipeline.threads.one_native_thread`); a closed stdout or stderr
is held on /dev/null before anything opens a file (:func:`_hold_closed_streams`)."""

from .memory import few_malloc_arenas, large_arrays_mapped, polars_returns_freed_pages
from .threads import one_native_thread


def main() -> None:
    _hold_closed_streams()
    polars_returns_freed_pages()
    large_arrays_mapped()
    few_malloc_arenas()
    one_native_thread()
    from .cli import StdoutError, app, guard_stdout, report_stdout_failure
    from .errors import ExitCode

    guard_stdout()
    try:
        app(prog_name="pipeline")
    except StdoutError as exc:  # --version, --help: written before any command's handler
        report_stdout_failure(exc)
        raise SystemExit(ExitCode.USER_ERROR) from None
    except SystemExit as exc:
        _exit_now_if_interrupted(exc.code)
        raise


def _hold_closed_streams() -> None:
    """Descriptors 1 and 2, when the command was started with them closed (``>&-``),
    opened on /dev/null before anything else opens a file: the next file opened would get
    the number, and whatever writes to the stream (a library's C code too) would write into
    it (a report, a user's log). ``sys.stdout`` stays None, which the command line turns
    into an error at the first write (:func:`pipeline.cli.guard_stdout`)."""
    import os

    for fd in (1, 2):
        try:
            os.fstat(fd)
        except OSError:
            devnull = os.open(os.devnull, os.O_WRONLY)
            if devnull != fd:  # 1 closed and 2 open: the lowest free number is 1 itself
                os.dup2(devnull, fd)
                os.close(devnull)


def _exit_now_if_interrupted(code) -> None:
    """A command stopped by SIGTERM or SIGINT (exit 128 + the signal) has run its
    ``finally`` blocks and said so: it exits here without the interpreter's finalization,
    which a pool's management or queue-feeder thread still running in C aborted once
    (SIGABRT, "the GIL is released" while finalizing; seen in CI)."""
    import os
    import sys

    if not isinstance(code, int) or code <= 128:  # every exit but a signal's: no import of
        return  # the batch layer (and through it scipy.signal, 1 s of CPU) for --version
    from .batch import SIGNALS

    if code not in {128 + int(s) for s in SIGNALS}:
        return
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # noqa: BLE001 - a closed stream: nothing more to say
            pass
    os._exit(code)


if __name__ == "__main__":
    main()
