"""The input formats, by name and by file suffix: the one list of them.

Each entry is the :class:`~pipeline.io.base.Format` its module declares. A new format is
a module with its options model, its loader and its ``FORMAT``, plus one line here; the
config (``data.format``'s choices and the format keys), the file discovery of a run and
the command line read this table.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import UserError
from . import columnar, dat, delimited, excel, mat, mcap
from .base import Format

FORMATS: dict[str, Format] = {f.name: f for f in (
    delimited.FORMAT, dat.FORMAT, mat.FORMAT, excel.FORMAT, columnar.FORMAT, mcap.FORMAT)}

#: file suffix (lower case, with the dot) -> format
SUFFIXES: dict[str, Format] = {s: f for f in FORMATS.values() for s in f.suffixes}

#: what ``data.format`` may say: the names and their aliases (``tsv`` -> csv)
NAMES: dict[str, Format] = {**FORMATS, **{a: f for f in FORMATS.values() for a in f.aliases}}


def find_format(path: Path, declared: str | None = None) -> Format | None:
    """The declared format, else the one of the file's suffix; None when neither is known."""
    if declared:
        return NAMES.get(declared)
    return SUFFIXES.get(path.suffix.lower())


def format_of(path: Path, declared: str | None = None) -> Format:
    """Like :func:`find_format`; an unknown format or suffix is a :class:`UserError`."""
    fmt = find_format(path, declared)
    if fmt is not None:
        return fmt
    if declared:
        raise UserError(f"{path}: unknown format {declared!r}; expected one of: "
                        f"{', '.join(NAMES)}")
    *most, last = SUFFIXES
    raise UserError(
        f"{path}: unknown file type {path.suffix!r}; expected {', '.join(most)} or {last} "
        "(or set data.format)"
    )


def formats_taking(key: str) -> list[str]:
    """The names of the formats whose options include ``key``."""
    return [f.name for f in FORMATS.values() if key in f.keys]
