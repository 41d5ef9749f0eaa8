"""Report assembly: results -> a template context -> report.md (+ PNGs), report.html
(one self-contained file, plots inline) and results.json, written into the output folder
by :func:`pipeline.report.outdir.publish` (staged inside it, replaced file by file: a crash
never leaves a half-written report, the user's files are kept).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager, ExitStack
from dataclasses import dataclass, field
from pathlib import Path

from jinja2 import Environment, PackageLoader, select_autoescape

from ..batch import deferred
from ..errors import UserError
from ..gate import Comparison
from ..grading import FLAGS
from ..results import RunResult, results_json
from ..schema import ResultsDoc
from .markdown import finalize, finalize_html, md_code, md_text
from .outdir import check_target, folder_lock, publish
from .regressions import mark_summary, regression_section
from .sections import FOLD_ROWS, collector, record_section, slug
from .tables import record_verdict, summary_table

MAX_FULL_RECORDS = 20  # "auto": above this, per-record sections keep one overview plot


@dataclass
class Extras:
    """Optional sections from the batch layer: the gate's comparison with a baseline
    (:mod:`pipeline.report.regressions` renders it) and the history figures."""

    comparison: Comparison | None = None
    history: list[tuple[str, bytes]] = field(default_factory=list)


def unique_anchors(names: list[str]) -> list[str]:
    """HTML anchors and plot-file stems, unique even where two names slug alike."""
    out, used = [], set()
    for name in names:
        base = a = slug(name)
        k = 1
        while a in used:
            k += 1
            a = f"{base}-{k}"
        used.add(a)
        out.append(a)
    return out


def render(run: RunResult, doc: ResultsDoc, *, title: str, extras: Extras | None = None,
           plots_mode: str = "auto", mapper=map) -> tuple[str, str, dict[str, bytes]]:
    """``(markdown, html, {png file name: bytes})`` for a run.

    ``plots_mode``: "full" (overview, ranking bars and the overlay views per record),
    "summary" (one overview per record), "none" (tables only), "auto" (full up to
    :data:`MAX_FULL_RECORDS` records, else summary). ``mapper`` maps
    :func:`record_section` over the records (``map``, or a process pool's ``map``).
    """
    files: dict[str, bytes] = {}
    add = collector(files)
    results = run.records
    mode = plots_mode if plots_mode != "auto" else (
        "full" if len(results) <= MAX_FULL_RECORDS else "summary")
    extras = extras or Extras()
    history = [add(f"history_{k}", t, png) for k, (t, png) in enumerate(extras.history)]
    anchors = unique_anchors([r.name for r in results])
    sections = []
    for section, section_files in mapper(record_section, results, [mode] * len(results),
                                         anchors):
        sections.append(section)
        files.update(section_files)
    names = [r.name for r in results]
    summary, gate = summary_table(results, anchors), None
    if extras.comparison is not None:
        gate = regression_section(extras.comparison, dict(zip(names, anchors, strict=True)))
        summary = mark_summary(summary, extras.comparison, names,
                               failed={r.name for r in results if not r.ok})
    ctx = {
        "title": title, "doc": doc, "created": shown_time(doc.created), "records": sections,
        "gate": gate,
        "summary": summary, "extras": extras, "history": history,
        "n_failed": sum(not r.ok for r in results), "flag_legend": FLAGS, "fold": FOLD_ROWS,
        "verdicts": {v: sum(record_verdict(r) == v for r in results)
                     for v in ("ok", "warning", "unreliable", "failed")},
    }
    md = _environment("md").get_template("report.md.j2").render(**ctx)
    html = _environment("html").get_template("report.html.j2").render(**ctx)
    return md, html, files


def shown_time(created: str) -> str:
    """results.json's ISO-8601 time as a report shows it: to the second, with its zone
    (``2026-12-06 13:21:18 UTC``); anything unreadable as given."""
    from datetime import datetime

    try:
        when = datetime.fromisoformat(created)
    except (TypeError, ValueError):
        return str(created)
    zone = when.strftime("%Z") if when.tzinfo is not None else ""
    return when.strftime("%Y-%m-%d %H:%M:%S") + (f" {zone}" if zone else "")


@functools.cache
def _environment(kind: str) -> Environment:
    """The template environment of report.md (every output escaped for Markdown,
    :mod:`pipeline.report.markdown`) or report.html (autoescaped for HTML)."""
    env = Environment(loader=PackageLoader("pipeline", "report/templates"),
                      autoescape=select_autoescape(["html.j2"]), trim_blocks=True,
                      lstrip_blocks=True, finalize=finalize if kind == "md" else finalize_html)
    env.filters["mdcell"] = md_text  # escaped text (a table cell's, too)
    env.filters["mdcode"] = md_code  # a code span
    return env


def write_run(out_dir: Path, run: RunResult, doc: ResultsDoc, *, title: str,
              extras: Extras | None = None, markdown: bool = True, html: bool = True,
              plots_mode: str = "auto", mapper=map,
              then: Callable[[], None] | None = None,
              locks: Sequence[AbstractContextManager] = ()) -> Path:
    """Write results.json, report.md (+ plots/) and report.html into ``out_dir``; then
    ``then()`` (the run's history row and JUnit file) under the same hold of SIGTERM and
    SIGINT, so an interrupted run leaves the previous outputs or all the new ones.
    ``locks`` (what ``then`` writes to: the history's) are taken, in order, before the
    folder's lock and before the signals are held, so a run waiting for one stops at once.

    The folder is created if need be; in an existing one only the run's own outputs are
    replaced (:mod:`pipeline.report.outdir`: staged inside the folder, then replaced file
    by file, reports last), whatever else it holds (a history file, the user's notes and
    plots) is kept. A failure is one :class:`UserError` line.
    """
    out_dir = Path(out_dir).resolve()
    check_target(out_dir)
    md, page, files = render(run, doc, title=title, extras=extras, plots_mode=plots_mode,
                             mapper=mapper)
    outputs = {"results.json": results_json(doc).encode("utf-8")}
    if markdown:
        outputs.update(files)
        outputs["report.md"] = md.encode("utf-8")
    if html:
        outputs["report.html"] = page.encode("utf-8")
    try:
        # the folder's lock is waited for before signals are held: a run waiting for
        # another's publish stops at once on SIGTERM
        with ExitStack() as held:
            for lock in locks:
                held.enter_context(lock)
            with folder_lock(out_dir), deferred():  # never half a report
                publish(out_dir, outputs, lock=False)
                if then is not None:
                    then()
    except OSError as exc:
        raise UserError(f"{out_dir}: cannot write the report ({exc.strerror or exc})") from None
    return out_dir
