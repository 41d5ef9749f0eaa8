"""The output folder a run writes into: staged inside itself, then replaced file by file.

* Everything a run writes is first written to a staging folder *inside* the output folder
  (``OUT/.pipeline.tmp-HOST-PID-XXXXXXXX``), so every later move is a rename on one
  filesystem: an output folder that is a mount point (a Docker volume, a CI artifacts
  mount) works, where a staging folder beside it fails with "Invalid cross-device link".
* Only then are the run's own files moved into place, one ``os.replace`` each, the plots
  first and the reports last: a run that dies before the swap leaves the previous report
  intact. A replaced file keeps its mode; a new one gets the umask's.
* The run's own files are :data:`OWNED` and the plots it writes, all listed in
  :data:`MANIFEST`; what an earlier run listed and this run does not write again is
  removed, nothing else: the user's own files (in ``plots/`` too, and a ``report.md`` in a
  folder no run wrote) are kept.
* A staging folder left by a killed run names its host and process id; the next run on
  that host removes those whose process is gone.
* Two runs onto one folder publish in turn (a lock file, ``.pipeline.lock``): the folder
  always holds one run's files, never a mix.
"""

from __future__ import annotations

import errno
import json
import os
import re
import shutil
import socket
import tempfile
import time
from pathlib import Path

from ..errors import UserError
from ..files import check_writable, default_mode, locked

#: The fixed names a run writes; one an earlier run's manifest lists and this run does not
#: write (report.md with ``markdown: false``) is removed, so the folder never mixes two
#: runs; one no run listed is the user's and stays.
OWNED = ("results.json", "report.md", "report.html")
#: The plots the last run wrote (a JSON list of ``plots/NAME.png``).
MANIFEST = ".pipeline-outputs.json"
STAGING = ".pipeline.tmp-"
#: The lock a publish holds (:func:`folder_lock`): concurrent runs onto one folder
#: publish in turn; one waits at most :data:`LOCK_WAIT` seconds for the other.
LOCK = ".pipeline.lock"
LOCK_WAIT = 120.0
_PLOT = re.compile(r"plots/[^/\\]+\.png")
# mkdtemp's random part is [a-z0-9_]{8}: no dash, so the pid is the last dashed number
_STALE = re.compile(re.escape(STAGING) + r"(?P<host>.+)-(?P<pid>\d+)-[a-z0-9_]+")


def host_tag() -> str:
    """This host in staging names: its name with anything but letters, digits and dots
    as ``_``."""
    return re.sub(r"[^A-Za-z0-9.]+", "_", socket.gethostname()) or "host"


def _alive(pid: int) -> bool:
    if pid <= 0:
        return True  # not a process id we wrote: leave it alone
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # PermissionError: someone else's live process
        return True
    return True


#: A staging folder lives for the seconds its files take to write; one of another host
#: (a CI container of a random name on a shared mount) older than this is a killed run's.
STALE_AGE = 3600.0


def check_target(out_dir: Path) -> None:
    """The report folder and its ``plots/`` can be written (before a batch: a file in the
    way costs no run), and ``plots/`` is no link (:func:`plots_link`); a problem is one
    :class:`~pipeline.errors.UserError` line."""
    check_writable(out_dir, "report folder", folder=True)
    link = plots_link(Path(out_dir))
    if link:
        raise UserError(link)
    check_writable(Path(out_dir) / "plots", "report's plots folder", folder=True)


def owned_file(out_dir: Path, path: Path) -> str | None:
    """What of the run's own in ``out_dir`` ``path`` names (a report, the manifest, the
    lock, anything under ``plots/`` or a staging folder), else None: a JUnit file or a
    history there would be replaced by the run's publish, or replace the report (issue
    31: ``--junit OUT/results.json`` left the JUnit XML as results.json, exit 0, and the
    next night's ``--baseline OUT/results.json`` was refused as not JSON)."""
    try:
        rel = Path(os.path.realpath(path)).relative_to(os.path.realpath(out_dir))
    except ValueError:
        return None
    parts = rel.parts
    if not parts:
        return "report folder"
    if len(parts) == 1 and parts[0] in (*OWNED, MANIFEST, LOCK):
        return parts[0]
    if parts[0] == "plots" or parts[0].startswith(STAGING):
        return f"{parts[0]} folder"
    return None


def plots_link(out_dir: Path) -> str | None:
    """Why ``OUT/plots`` may not be written, when it is a symbolic link (else None): a run
    writes and removes its plots only inside the output folder, never through a link that
    may leave it (issue 31: a ``plots`` link made a run delete an earlier run's plot in the
    folder it pointed to, and write its new plots there)."""
    plots = out_dir / "plots"
    try:
        if not plots.is_symlink():
            return None
        target = os.readlink(plots)
    except OSError as exc:  # a folder that cannot be searched; a link gone meanwhile
        return f"{plots}: cannot check the report's plots folder ({exc.strerror or exc})"
    return (f"{plots}: cannot write the report's plots (is a link to {target}); "
            "a run writes its plots only into a folder of its own: remove the link, or "
            "write the report elsewhere")


def remove_stale(out_dir: Path) -> list[Path]:
    """Remove the staging folders in ``out_dir`` that killed runs left behind: on this
    host those whose process is gone, of another host those older than
    :data:`STALE_AGE`; returns what was removed."""
    removed = []
    host = host_tag()
    now = time.time()
    for entry in out_dir.iterdir():
        m = _STALE.fullmatch(entry.name)
        if not m:
            continue
        try:
            old = now - entry.lstat().st_mtime > STALE_AGE
        except OSError:
            continue
        dead = not _alive(int(m["pid"])) if m["host"] == host else old
        if dead and entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
            removed.append(entry)
    return removed


def _previous_outputs(out_dir: Path) -> set[str]:
    """What the last run listed in its manifest (names of the plot form and of
    :data:`OWNED`); nothing without a manifest: a folder no run wrote holds only the
    user's files (issue 31: ``markdown: false`` removed a user's own report.md). A
    manifest of an older version lists its plots only; its run wrote :data:`OWNED` too."""
    try:
        names = json.loads((out_dir / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return set()
    if not isinstance(names, list):
        return set()
    listed = {n for n in names if isinstance(n, str) and (_PLOT.fullmatch(n) or n in OWNED)}
    return listed if listed & set(OWNED) else listed | set(OWNED)


def folder_lock(out_dir: Path):
    """The lock two runs onto one folder publish under, one after the other (moved file
    by file, two interleaved publishes left one run's results.json beside the other's
    report): ``OUT/.pipeline.lock``, waited for at most :data:`LOCK_WAIT` seconds."""
    out_dir.mkdir(parents=True, exist_ok=True)
    return locked(out_dir, "the report folder", LOCK_WAIT,
                  "this run's reports were not written", lock_file=out_dir / LOCK)


def publish(out_dir: Path, files: dict[str, bytes], *, lock: bool = True) -> None:
    """Write ``files`` (relative name -> bytes; names are :data:`OWNED` or
    ``plots/NAME.png``) into ``out_dir``: staged inside it, then replaced one by one, plots
    first and ``report.html`` last, under :func:`folder_lock` (``lock=False``: the caller
    holds it). Raises ``OSError``; the staging folder never stays."""
    if lock:
        with folder_lock(out_dir):
            _publish(out_dir, files)
    else:
        out_dir.mkdir(parents=True, exist_ok=True)
        _publish(out_dir, files)


def _publish(out_dir: Path, files: dict[str, bytes]) -> None:
    order = sorted(files, key=lambda n: (n in OWNED, OWNED.index(n) if n in OWNED else 0))
    link = plots_link(out_dir)  # made since check_target (a narrower race remains)
    if link:
        raise OSError(errno.ELOOP, link)
    remove_stale(out_dir)
    stage = Path(tempfile.mkdtemp(prefix=f"{STAGING}{host_tag()}-{os.getpid()}-", dir=out_dir))
    try:
        for name in order:
            (stage / name).parent.mkdir(exist_ok=True)
            (stage / name).write_bytes(files[name])
        (stage / MANIFEST).write_text(json.dumps(sorted(files)), encoding="utf-8")
        gone = _previous_outputs(out_dir) - set(files)
        for name in order:
            _move(stage / name, out_dir / name)
        for name in sorted(gone):  # an earlier run's outputs this run does not write
            old = out_dir / name
            if old.is_file() or old.is_symlink():
                old.unlink()
        _move(stage / MANIFEST, out_dir / MANIFEST)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _move(src: Path, dst: Path) -> None:
    """``os.replace`` keeping the replaced file's mode (a new file: the umask's)."""
    dst.parent.mkdir(exist_ok=True)  # plots/ the first time, with the umask's mode
    try:
        mode = dst.stat().st_mode & 0o777 if dst.is_file() else default_mode()
    except OSError:
        mode = default_mode()
    os.chmod(src, mode)
    os.replace(src, dst)
