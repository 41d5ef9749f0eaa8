"""The regression gate's files: read a baseline and check it belongs to this run; promote a
results.json to be the baseline (:func:`accept`). The comparison itself is pure
(:mod:`pipeline.gate.baseline`).

Which baseline a run accepts (:func:`check_baseline`, before the batch, so a wrong one
costs no run; each refusal is one line naming the baseline file, exit code 2):

1. **The same config.** A baseline made by a config of another file name is refused, the
   line naming both (``configs/a.yaml`` and ``/ci/checkout/configs/a.yaml`` are the same
   config: a CI checkout moves the folder, so only the file name is compared). A
   document that names no config (built by hand, a very old version) passes this check.
2. **Shared records.** Records are matched by name; the log files may move (a folder per
   night), so the sources are not compared. A baseline that shares no record with the
   run is refused. When some are shared, the baseline's records that this run does not
   have are listed as *missing* (a regression when they were ok) and the run's new ones
   as *new*, as :func:`pipeline.gate.compare` documents.
3. **Shared methods.** When the config lists its methods and none of the baseline's fits
   was made by one of them, the baseline is refused (every fit would be missing). When
   some are shared, a fit of a method the config no longer runs is *missing*.

A file that is not JSON, JSON of another shape (including nesting too deep to parse) or
of an unreadable schema version is refused the same way.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from pathlib import Path

from ..errors import UserError
from ..files import read_text, write_atomic
from ..results import parse_results
from ..schema import ResultsDoc


def load_results(path: str | os.PathLike) -> ResultsDoc:
    """Read and validate a results.json (or baseline) file."""
    p = Path(path)
    return parse_results(read_text(p, "results file"), str(p))


def _names(items: Iterable[str], limit: int = 3) -> str:
    items = sorted(set(items))
    shown = ", ".join(repr(i)[:40] for i in items[:limit])
    return shown + (f" and {len(items) - limit} more" if len(items) > limit else "")


def check_baseline(doc: ResultsDoc, where: str, *, config: str | None = None,
                   records: Iterable[str] | None = None,
                   methods: Iterable[str] | str | None = None) -> ResultsDoc:
    """``doc`` when it is a baseline of this run (the module docstring's rules), else a
    :class:`UserError` naming ``where``. ``config`` is the run's config path, ``records``
    the names of its records, ``methods`` the config's method ids (or "all")."""
    accept_cmd = "make one with `pipeline baseline accept <results.json>`"
    _finite_parameters(doc, where, accept_cmd)
    if config and doc.config and Path(doc.config).name != Path(config).name:
        raise UserError(f"{where}: a baseline of config {doc.config!r}, not of this run's "
                        f"{config!r}; expected a baseline of the same config ({accept_cmd})")
    base_names = {r.name for r in doc.records}
    if records is not None:
        names = set(records)
        if names and base_names and not names & base_names:
            raise UserError(f"{where}: shares no record with this run (baseline: "
                            f"{_names(base_names)}; this run: {_names(names)}); expected a "
                            f"baseline of the same records ({accept_cmd})")
    if methods is not None and methods != "all":
        wanted = set(methods)
        used = {f.method for r in doc.records for f in r.fits}
        if wanted and used and not wanted & used:
            raise UserError(f"{where}: no fit in the baseline is of a method this config "
                            f"runs (baseline: {_names(used)}; config: {_names(wanted)}); "
                            f"expected a baseline of the same methods ({accept_cmd})")
    return doc


def _finite_parameters(doc: ResultsDoc, where: str, accept_cmd: str) -> None:
    """Every parameter of the baseline's fits and recommended models is a finite number
    or null: a NaN compares false with everything, so it turned the gate off (a doubled
    gain passed with exit 0, issue 31)."""
    for rec in doc.records:
        shown = [(f"fit {f.method!r} (event {f.event})", f.params) for f in rec.fits]
        if rec.recommended is not None:
            shown.append(("the recommended model", rec.recommended.params))
        for label, params in shown:
            for name, value in (params or {}).items():
                if isinstance(value, float) and not math.isfinite(value):
                    raise UserError(f"{where}: record {rec.name!r}, {label}: parameter "
                                    f"{name!r} is {value}; a baseline's parameters must be "
                                    f"numbers ({accept_cmd})")


def load_baseline(path: str | os.PathLike, *, config: str | None = None,
                  records: Iterable[str] | None = None,
                  methods: Iterable[str] | str | None = None) -> ResultsDoc:
    """Read the baseline at ``path`` and check that it belongs to this run
    (:func:`check_baseline`)."""
    return check_baseline(load_results(path), str(path), config=config, records=records,
                          methods=methods)


def accept(results_path: str | os.PathLike, to_path: str | os.PathLike) -> Path:
    """Make ``results_path`` the baseline at ``to_path`` (validated, written atomically).

    The bytes are copied unchanged; the target folder is created. Returns ``to_path``.
    """
    src = Path(results_path)
    # refuse to accept something that is not a valid results file, or one with NaNs
    _finite_parameters(load_results(src), str(src), "re-run it")
    dst = Path(to_path)
    write_atomic(dst, src.read_bytes(), "baseline")
    return dst
