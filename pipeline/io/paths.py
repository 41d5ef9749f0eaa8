"""Which files a config's ``data.path`` (or an entry of ``data.paths``) names.

A folder names its log files (those of a known suffix, :data:`~.registry.SUFFIXES`); a
glob pattern (``logs/*.csv``, ``**/run?.dat``) the log files it matches; anything else,
and a file that exists, is that one file, read literally: ``run[1].csv`` is the file of
that name, not ``run1.csv`` (issue 13). A pattern relative to the config's folder is
matched inside it (``glob``'s ``root_dir``), so glob characters in the folder's own name
are not read as a pattern either.

Links (issue 31): a folder or a pattern names the files *inside* it. A recursive pattern
(``**``) walks the folders without entering linked ones (:func:`os.walk`,
``followlinks=False``): a link to ``.`` turned one log into 41 records, two link loops hung
the glob. A matched file that is a link to a file outside the folder the pattern starts in
is refused with a :class:`~pipeline.errors.UserError` naming the link (a link to a
credentials file put its content into the report); the same file reached twice is one
record.
"""

from __future__ import annotations

import glob
import os
import re
from pathlib import Path

from ..errors import UserError
from .registry import SUFFIXES


def files_named(pattern: str, base: Path) -> list[Path]:
    """The files ``pattern`` names, relative to ``base`` (see the module docstring)."""
    path = Path(os.path.normpath(pattern if Path(pattern).is_absolute() else base / pattern))
    if path.is_dir():
        hits = [f for f in path.iterdir() if f.suffix.lower() in SUFFIXES and f.is_file()]
        return _inside(sorted(hits), path)
    if path.exists() or not glob.has_magic(pattern):
        return [path]
    root = _literal_root(path)
    if "**" in Path(pattern).parts:
        hits = _walk(root, path)
    elif Path(pattern).is_absolute():
        hits = [Path(f) for f in glob.glob(pattern)]
    else:
        hits = [Path(os.path.normpath(base / f)) for f in glob.glob(pattern, root_dir=base)]
    return _inside(sorted(f for f in hits if f.is_file() and f.suffix.lower() in SUFFIXES),
                   root)


def _literal_root(path: Path) -> Path:
    """The folder before the first component with a glob character."""
    parts = path.parts
    k = next((i for i, part in enumerate(parts) if glob.has_magic(part)), len(parts))
    return Path(*parts[:k]) if k else Path(".")


def _walk(root: Path, pattern: Path) -> list[Path]:
    """The files under ``root`` whose path matches ``pattern`` (``**`` any number of
    folders, ``*``/``?``/``[...]`` within one name), linked folders not entered."""
    regex = re.compile(_regex(pattern.relative_to(root).parts))
    out = []
    for folder, dirs, names in os.walk(root, followlinks=False):
        dirs.sort()
        rel = Path(folder).relative_to(root)
        for name in names:
            if regex.fullmatch((rel / name).as_posix()):
                out.append(Path(folder) / name)
    return out


def _regex(parts: tuple[str, ...]) -> str:
    """A regular expression of glob path components: ``**`` zero or more folders (not
    hidden ones), ``*`` and ``?`` within one name, ``[...]`` (``[!...]``) a class; a name
    starting with ``*``, ``?`` or ``[`` does not match a hidden name, as :mod:`glob`."""
    out = ""
    for k, part in enumerate(parts):
        last = k == len(parts) - 1
        if part == "**":
            out += "(?:(?!\\.)[^/]+/)*" if not last else "(?:(?!\\.)[^/]+/)*[^/]*"
            continue
        hidden = "(?!\\.)" if part[:1] in "*?[" else ""
        out += hidden + _name_regex(part) + ("" if last else "/")
    return out


def _name_regex(name: str) -> str:
    out, i = "", 0
    while i < len(name):
        c = name[i]
        if c == "*":
            out += "[^/]*"
        elif c == "?":
            out += "[^/]"
        elif c == "[" and name.find("]", i + 2) > 0:
            j = name.find("]", i + 2)
            body = name[i + 1:j]
            neg = body.startswith("!")
            body = body[1:] if neg else body
            out += "[" + ("^" if neg else "") + body.replace("\\", "\\\\") + "]"
            i = j
        else:
            out += re.escape(c)
        i += 1
    return out


def _inside(files: list[Path], folder: Path) -> list[Path]:
    """``files`` once each (by their real path), refusing one that is a link to a file
    outside ``folder``."""
    top = folder.resolve()
    seen, out = set(), []
    for f in files:
        real = f.resolve()
        if real != top and top not in real.parents:
            raise UserError(f"{f}: a link to a file outside {folder} ({real.name}); data "
                            "folders and patterns name the files inside them: name the "
                            "file itself, or copy it in")
        if real not in seen:
            seen.add(real)
            out.append(f)
    return out
