"""``python -m pipeline`` and the ``pipeline`` command: the command line, in a process that
is the command's own, so polars' allocator is set up first (:func:`pipeline.memory.
polars_returns_freed_pages`, before anything imports polars; pool workers inherit it), and
glibc's mmap threshold fixed (:func:`pipeline.memory.large_arrays_mapped`), and one
native BLAS thread (:func:`pipeline.threads.one_native_thread`)."""

from .memory import large_arrays_mapped, polars_returns_freed_pages
from .threads import one_native_thread


def main() -> None:
    polars_returns_freed_pages()
    large_arrays_mapped()
    one_native_thread()
    from .cli import StdoutError, app, guard_stdout, report_stdout_failure
    from .errors import ExitCode

    guard_stdout()
    try:
        app(prog_name="pipeline")
    except StdoutError as exc:  # --version, --help: written before any command's handler
        report_stdout_failure(exc)
        raise SystemExit(ExitCode.USER_ERROR) from None


if __name__ == "__main__":
    main()
