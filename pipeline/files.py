"""File helpers shared by the edges (config, results, reports, logs): a read and an atomic
write (temporary file beside the target, then ``os.replace``: a crash never leaves a
half-written file) that fail as one :class:`~pipeline.errors.UserError` line."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from .errors import UserError


def read_text(path: str | os.PathLike, what: str) -> str:
    """The text of ``path``; a missing or unreadable file names ``what`` it should be."""
    p = Path(path)
    try:
        return p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise UserError(f"{p}: {what} not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{p}: cannot read the {what} ({exc})") from None


def default_mode(directory: bool = False) -> int:
    """The mode a new file (or folder) gets under the process's umask, as ``open`` and
    ``mkdir`` would give it (``mkstemp``/``mkdtemp`` create them private)."""
    mask = os.umask(0)
    os.umask(mask)
    return (0o777 if directory else 0o666) & ~mask


def write_atomic(path: str | os.PathLike, data: bytes, what: str = "file") -> None:
    """Write ``data`` to a temporary file beside ``path``, then ``os.replace`` it; the
    folder is created, a replaced file keeps its mode (a new one gets the umask's), and a
    failure is one :class:`UserError` line naming ``path`` and ``what`` it is."""
    path = Path(path)
    tmp = None
    try:
        if path.is_dir():
            raise IsADirectoryError(21, "is a folder")
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
