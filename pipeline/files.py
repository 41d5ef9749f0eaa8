"""File helpers shared by the edges (config, results, reports, logs): a read and an atomic
write (temporary file beside the target, then ``os.replace``: a crash never leaves a
half-written file) that fail as one :class:`~pipeline.errors.UserError` line."""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from .errors import UserError


def read_text(path: str | os.PathLike, what: str) -> str:
    """The text of ``path``; a missing or unreadable file names ``what`` it should be. Only
    a regular file is read: a device (``/dev/zero`` would fill the memory) or a FIFO
    (whose reader waits for a writer that may never come) is refused before it is
    opened."""
    p = Path(path)
    try:
        refuse_special(p, f"expected the {what}")
        return p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise UserError(f"{p}: {what} not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{p}: cannot read the {what} ({exc})") from None


def refuse_special(path: Path, expected: str) -> None:
    """A :class:`UserError` when ``path`` exists and is not a regular file or a folder: a
    device (``/dev/zero`` read to the end fills the memory), a FIFO (opening it waits for
    a writer, or a reader, that may never come), a socket. Checked with ``stat``, which
    does not open it (issue 31: ``--baseline /dev/zero``, a ``--history`` FIFO)."""
    try:
        mode = path.stat().st_mode
    except OSError:
        return  # missing or unreachable: the caller's own error says so
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return
    kind = "a pipe" if stat.S_ISFIFO(mode) else "a device" if (
        stat.S_ISCHR(mode) or stat.S_ISBLK(mode)) else "a socket" if stat.S_ISSOCK(mode) \
        else "a special file"
    raise UserError(f"{path}: {kind}, not a regular file; {expected}")


def _umask() -> int:
    """The process's umask. Read from ``/proc`` where there is one: setting it to read it
    back (the portable way) leaves it 0 for a moment, when another thread's new file
    would be world-writable."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def default_mode(directory: bool = False) -> int:
    """The mode a new file (or folder) gets under the process's umask, as ``open`` and
    ``mkdir`` would give it (``mkstemp``/``mkdtemp`` create them private: 0600, 0700)."""
    return (0o777 if directory else 0o666) & ~_umask()


def check_writable(path: str | os.PathLike, what: str, *, folder: bool = False) -> None:
    """Check, without creating anything, that ``path`` can be written as a file (or a
    ``folder``): it is not the other kind, the nearest existing folder above it is a
    folder and writable. A problem is one :class:`UserError` line naming ``path``,
    ``what`` it is and why (run before a batch, so a bad target costs no run)."""
    p = Path(path)
    if p.is_dir() and not folder:
        raise UserError(f"{p}: cannot write the {what} (is a folder); expected a file")
    refuse_special(p, f"cannot write the {what} there")
    if p.exists() and folder and not p.is_dir():
        raise UserError(f"{p}: cannot write the {what} (is a file); expected a folder")
    if p.is_dir():
        nearest = p
    else:
        nearest = p.parent
        while not nearest.exists() and nearest != nearest.parent:
            nearest = nearest.parent  # exists() is False below a file: find that file
        if not nearest.is_dir():
            raise UserError(f"{p}: cannot write the {what} ({nearest} is a file, not a "
                            f"folder)")
    if not os.access(nearest, os.W_OK | os.X_OK,
                     effective_ids=os.access in os.supports_effective_ids):
        raise UserError(f"{p}: cannot write the {what} ({nearest} is not writable)")


def through_link(path: Path, what: str) -> Path:
    """The file a symbolic link ``path`` names (followed to its end; a dangling link's
    would-be target), so that a write replaces that file and the link stays (issue 31:
    a ``--history`` link to a shared file was replaced by a regular file, and the shared
    file never got the row); ``path`` itself when it is no link. A link to something that
    is not a regular file is one :class:`UserError` line."""
    if not path.is_symlink():
        return path
    target = Path(os.path.realpath(path))
    if target.is_symlink():  # realpath stops inside a loop of links
        raise UserError(f"{path}: cannot write the {what} (a loop of symbolic links)")
    if target.exists() and not target.is_file():
        raise UserError(f"{path}: cannot write the {what} (a link to {target}, which is not "
                        "a regular file)")
    return target


def write_atomic(path: str | os.PathLike, data: bytes, what: str = "file", *,
                 through: bool = False) -> None:
    """Write ``data`` to a temporary file beside ``path``, then ``os.replace`` it; the
    folder is created, a replaced file keeps its mode (a new one gets the umask's), with
    ``through`` a symbolic link is written through (:func:`through_link`: the link stays;
    the history and JUnit files, which are shared), and a failure is one
    :class:`UserError` line naming ``path`` and ``what`` it is."""
    path = through_link(Path(path), what) if through else Path(path)
    tmp = None
    check_writable(path, what)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        mode = path.stat().st_mode & 0o777 if path.exists() else default_mode()
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except OSError as exc:
        raise UserError(f"{path}: cannot write the {what} ({exc.strerror or exc})") from None
    finally:
        if tmp is not None and Path(tmp).exists():
            Path(tmp).unlink(missing_ok=True)


def same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` name one file (through links, hard links and ``..``); two
    paths of which one does not exist yet are one file when they resolve alike."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def refuse_input(target: Path, what: str, inputs: list[tuple[Path, str]]) -> None:
    """An output (``target``, ``what`` it is) that names one of the run's ``inputs``
    (``(path, what it is)``: the config, a log, the baseline, another output) is one
    :class:`UserError` line: an output never replaces what the run reads."""
    for path, name in inputs:
        if same_file(target, path):
            raise UserError(f"{target}: the {what} would replace {name} ({path}); give "
                            "another path")


@contextmanager
def locked(path: Path, what: str, wait: float, lost: str, *,
           lock_file: Path | None = None) -> Iterator[None]:
    """An exclusive lock on ``lock_file`` (default ``NAME.lock`` beside ``path``; filelock)
    while the block runs: one run at a time reads, adds to and replaces ``what`` at
    ``path`` (a history, an output folder). A lock another run holds for longer than
    ``wait`` seconds is one :class:`UserError` naming ``path``, saying so and what was not
    done (``lost``)."""
    from filelock import FileLock, Timeout

    lock_file = lock_file or path.parent / f"{path.name}.lock"
    lock = FileLock(str(lock_file), timeout=wait)
    try:
        lock_file.parent.mkdir(parents=True, exist_ok=True)
        lock.acquire()
    except Timeout:
        raise UserError(f"{path}: another run has held {what} for {wait:g} s; {lost}"
                        ) from None
    except OSError as exc:
        raise UserError(f"{path}: cannot lock {what} ({exc.strerror or exc})") from None
    try:
        yield
    finally:
        lock.release()
