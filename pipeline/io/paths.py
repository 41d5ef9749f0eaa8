"""Which files a config's ``data.path`` (or an entry of ``data.paths``) names.

A folder names its log files (those of a known suffix, :data:`~.registry.SUFFIXES`); a
glob pattern (``logs/*.csv``, ``**/run?.dat``) the log files it matches; anything else,
and a file that exists, is that one file, read literally: ``run[1].csv`` is the file of
that name, not ``run1.csv`` (issue 13). A pattern relative to the config's folder is
matched inside it (``glob``'s ``root_dir``), so glob characters in the folder's own name
are not read as a pattern either.
"""

from __future__ import annotations

import glob
import os
from pathlib import Path

from .registry import SUFFIXES


def files_named(pattern: str, base: Path) -> list[Path]:
    """The files ``pattern`` names, relative to ``base`` (see the module docstring)."""
    path = Path(os.path.normpath(pattern if Path(pattern).is_absolute() else base / pattern))
    if path.is_dir():
        return sorted(f for f in path.iterdir() if f.suffix.lower() in SUFFIXES)
    if path.exists() or not glob.has_magic(pattern):
        return [path]
    if Path(pattern).is_absolute():
        hits = [Path(f) for f in glob.glob(pattern, recursive=True)]
    else:
        hits = [Path(os.path.normpath(base / f))
                for f in glob.glob(pattern, root_dir=base, recursive=True)]
    return sorted(f for f in hits if f.is_file() and f.suffix.lower() in SUFFIXES)
