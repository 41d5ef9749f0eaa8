"""A native reader's panic text kept off the terminal.

polars' readers are Rust: a damaged file they do not check (a Parquet page whose bytes
were flipped) makes one panic, and Rust's panic hook writes its message and a backtrace
note straight to descriptor 2 before pyo3 raises ``PanicException``. The loader turns the
exception into one line naming the file (:func:`pipeline.io.load_record`), but the six
lines the hook wrote before it broke the one-line promise (issue 31; in-process tests did
not see them: they are below ``sys.stderr``). No setting of polars or Rust silences the
hook, so descriptor 2 is held on a temporary file while a reader runs: what was written
there is written on to the real stderr afterwards, unless the reader panicked.
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def panic_text_held() -> Iterator[None]:
    """Descriptor 2 on a temporary file while the block runs; its content copied to the
    real descriptor 2 afterwards, except when the block raised a native panic
    (``PanicException``, or an error raised while handling one: the hook's text; the
    error says the same in one line). Where
    descriptor 2 cannot be duplicated the block runs as it is."""
    try:
        saved = os.dup(2)
    except OSError:
        yield
        return
    panicked = False
    with tempfile.TemporaryFile() as held:
        _flush()
        os.dup2(held.fileno(), 2)
        try:
            yield
        except BaseException as exc:
            panicked = _from_panic(exc)
            raise
        finally:
            _flush()
            os.dup2(saved, 2)
            os.close(saved)
            if not panicked:
                held.seek(0)
                text = held.read()
                if text:
                    _write_all(text)


def _from_panic(exc: BaseException | None) -> bool:
    """Whether ``exc`` is a native panic or was raised while handling one (a loader's
    one-line error ``from None`` keeps the panic as its context)."""
    seen = 0
    while exc is not None and seen < 8:
        if type(exc).__name__ == "PanicException":
            return True
        exc, seen = exc.__cause__ or exc.__context__, seen + 1
    return False


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):
            pass


def _write_all(data: bytes) -> None:
    try:
        while data:
            data = data[os.write(2, data):]
    except OSError:  # a closed stderr: nothing more to say
        pass
