"""The dataset registry: public datasets by name, fetched with a sha256 check.

The registry ships inside the package (``pipeline/data/datasets.yaml``; the environment
variable ``PIPELINE_DATASETS_REGISTRY`` names another file). Resolution order for
``fetch(name)``: the download cache (the user's cache directory, e.g.
``~/.cache/pipeline/datasets/NAME/FILE``, or ``PIPELINE_DATASETS_CACHE``), then the folder
named by ``PIPELINE_DATASETS_MIRROR`` (``MIRROR/<mirror_path>``), then the official URL
(decompressed when the entry says ``compression: gzip``). The sha256 is checked every
time; the cache is written atomically. Works the same from a source checkout and from an
installed wheel, from any folder.

Downloads go through pooch (HTTP(S) and FTP, each with a timeout; decompression; a
progress bar on a terminal), tried again :data:`RETRIES` times after a dropped connection
or a bad hash (the stored file's, after decompression, included); pooch is imported only
when a download is needed: it brings requests, which a run from the mirror or the cache
never loads.
"""

from __future__ import annotations

import ftplib
import hashlib
import os
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from ..errors import UserError
from ..files import default_mode

MIRROR_ENV = "PIPELINE_DATASETS_MIRROR"
REGISTRY_ENV = "PIPELINE_DATASETS_REGISTRY"
CACHE_ENV = "PIPELINE_DATASETS_CACHE"
#: downloads tried again after the first fails, waiting RETRY_WAIT s, then twice that
RETRIES = 2
RETRY_WAIT = 1.0
#: seconds a connection may stay silent before the attempt fails (a stalled server)
TIMEOUT = 30.0
#: the URL schemes a download may use
SCHEMES = ("http", "https", "ftp")


@dataclass(frozen=True)
class Dataset:
    name: str
    title: str
    url: str
    file: str
    sha256: str
    format: str
    input: str
    output: str
    time: str | None = None
    columns: list[str] | None = None
    units: dict[str, str] = field(default_factory=dict)
    initial_input: float | None = None
    compression: str | None = None
    mirror_path: str | None = None
    landing_page: str = ""
    description: str = ""
    citation: str = ""


def registry_path() -> Path:
    """The registry file: ``$PIPELINE_DATASETS_REGISTRY``, else the one in the package."""
    env = os.environ.get(REGISTRY_ENV)
    return Path(env) if env else Path(__file__).resolve().parent.parent / "data" / "datasets.yaml"


def cache_dir() -> Path:
    """Where fetched datasets are kept: ``$PIPELINE_DATASETS_CACHE``, else the user's cache
    directory (platformdirs)."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env)
    from platformdirs import user_cache_dir

    return Path(user_cache_dir("pipeline", appauthor=False)) / "datasets"


def shown_source(source: str) -> str:
    """A record's source as a report shows it: a fetched dataset as ``dataset NAME:
    FILE`` (not the cache path of the machine that ran it), a file under the working
    folder relative to it, anything else as given."""
    path = Path(source)
    for root, dataset in ((cache_dir(), True), (Path.cwd(), False)):
        try:
            rel = path.resolve().relative_to(root.resolve())
        except (ValueError, OSError):
            continue
        if dataset and len(rel.parts) >= 2:
            return f"dataset {rel.parts[0]}: {Path(*rel.parts[1:])}"
        if not dataset:
            return str(rel)
    return source


def load_registry(path: Path | None = None) -> dict[str, Dataset]:
    path = path or registry_path()
    try:
        raw = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    except FileNotFoundError:
        raise UserError(f"{path}: dataset registry not found; set {REGISTRY_ENV} to a "
                        "registry file") from None
    except yaml.YAMLError as exc:
        raise UserError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
    out = {}
    for name, entry in raw.items():
        try:
            out[name] = Dataset(name=name, **entry)
        except TypeError as exc:
            raise UserError(f"{path}: dataset {name!r}: {exc}") from None
    return out


def dataset(name: str) -> Dataset:
    reg = load_registry()
    if name not in reg:
        raise UserError(
            f"unknown dataset {name!r}; known datasets: {', '.join(sorted(reg)) or 'none'} "
            "(see `pipeline datasets list`)"
        )
    return reg[name]


def sha256_of(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def fetch(name: str, *, offline: bool = False) -> Path:
    """Path of the verified local copy of dataset ``name`` (fetched if needed)."""
    ds = dataset(name)
    target = cache_dir() / ds.name / ds.file
    if target.is_file():
        if sha256_of(target) == ds.sha256:
            return target
        target.unlink()  # a corrupt cache entry is refetched, never used
    mirror = os.environ.get(MIRROR_ENV)
    tried = []
    if mirror:
        cand = Path(mirror) / (ds.mirror_path or f"{ds.name}/{ds.file}")
        tried.append(str(cand))
        if cand.is_file():
            if sha256_of(cand) != ds.sha256:
                raise UserError(
                    f"{cand}: sha256 {sha256_of(cand)} does not match the registry's "
                    f"{ds.sha256} for dataset {name!r}"
                )
            return _install(cand, target, ds)
    if not offline:
        tried.append(ds.url)
        try:
            return _download(ds, target)
        except (*ftplib.all_errors, ValueError) as exc:  # requests' errors are OSErrors
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            tried[-1] += f" ({reason})"
    raise UserError(
        f"dataset {name!r} is not available (tried {'; '.join(tried) or 'nothing'}); download "
        f"{ds.url} yourself and set {MIRROR_ENV} to a folder holding "
        f"{ds.mirror_path or ds.name + '/' + ds.file}"
    )


def _install(src: Path, target: Path, ds: Dataset) -> Path:
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=".part-")
    os.close(fd)
    shutil.copyfile(src, tmp)
    os.chmod(tmp, default_mode())  # mkstemp makes it 0600: the cache is shared like any file
    os.replace(tmp, target)
    return target


def _download(ds: Dataset, target: Path) -> Path:
    """:func:`_download_once`, tried again :data:`RETRIES` times when it fails (a dropped
    connection, a timeout, a bad hash); the last failure is raised. A URL no downloader
    takes fails at once."""
    scheme = ds.url.split(":", 1)[0].lower()
    if scheme not in SCHEMES:
        raise ValueError(f"unsupported URL scheme {scheme!r}; expected http, https or ftp")
    for attempt in range(RETRIES + 1):
        try:
            return _download_once(ds, target)
        except (*ftplib.all_errors, ValueError):
            if attempt == RETRIES:
                raise
            time.sleep(RETRY_WAIT * (attempt + 1))
    raise AssertionError("unreachable")


def _download_once(ds: Dataset, target: Path) -> Path:
    """Fetch ``ds.url`` with pooch into a staging folder beside ``target``, decompress it
    when the entry says so, check the sha256 of the file as stored and move it into place
    (so a failed or interrupted download never leaves a file the cache would serve)."""
    import pooch

    target.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(dir=target.parent, prefix=".part-"))
    remote = ds.url.rsplit("/", 1)[-1] or ds.file
    if ds.compression and remote == ds.file:
        remote += ".download"  # the decompressed file must not be written onto its input
    # the registry's sha256 is the stored (decompressed) file's: pooch checks it on a plain
    # download; a compressed one is checked after decompression, below
    known = None if ds.compression else f"sha256:{ds.sha256}"
    fetcher = pooch.create(path=staging, base_url="", registry={remote: known},
                           urls={remote: ds.url})
    processor = (pooch.Decompress(method=ds.compression, name=ds.file)
                 if ds.compression else None)
    logger = pooch.get_logger()
    level = logger.level
    logger.setLevel("WARNING")  # not pooch's "Downloading file ..." lines on every fetch
    bar = _ProgressBar(ds.name) if sys.stderr.isatty() else False
    try:
        got = Path(fetcher.fetch(remote, processor=processor,
                                 downloader=_downloader(pooch, ds.url, bar)))
        digest = sha256_of(got)
        if digest != ds.sha256:
            raise ValueError(f"sha256 mismatch: got {digest}, expected {ds.sha256}")
        os.chmod(got, default_mode())  # the cache is shared like any file
        os.replace(got, target)
        return target
    finally:
        logger.setLevel(level)
        if bar:
            bar.close()
        shutil.rmtree(staging, ignore_errors=True)


def _downloader(pooch, url: str, bar):
    """pooch's downloader for ``url``'s scheme (one of :data:`SCHEMES`), with
    :data:`TIMEOUT` (pooch's FTP one has none by default: a stalled server would hang
    the run)."""
    if url.split(":", 1)[0].lower() == "ftp":
        return pooch.FTPDownloader(timeout=TIMEOUT, progressbar=bar)
    return pooch.HTTPDownloader(timeout=TIMEOUT, progressbar=bar)


class _ProgressBar:
    """pooch's custom progress-bar protocol (``total``, ``update``, ``reset``, ``close``),
    drawn by rich on stderr; pooch's own bar would need tqdm."""

    def __init__(self, label: str):
        from rich.console import Console
        from rich.progress import BarColumn, DownloadColumn, Progress, TextColumn

        self._progress = Progress(TextColumn(label), BarColumn(), DownloadColumn(),
                                  console=Console(stderr=True), transient=True)
        self._task = self._progress.add_task(label, total=None)
        self._progress.start()
        self._open = True

    @property
    def total(self) -> float | None:
        return self._progress.tasks[0].total

    @total.setter
    def total(self, value: float | None) -> None:
        self._progress.update(self._task, total=value or None)

    def update(self, n: float) -> None:
        self._progress.advance(self._task, n)

    def reset(self) -> None:
        self._progress.update(self._task, completed=0)

    def close(self) -> None:
        if self._open:
            self._open = False
            self._progress.stop()
