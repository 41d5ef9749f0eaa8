"""Report assembly: results -> a template context -> report.md (+ PNGs), report.html
(one self-contained file, plots inline) and results.json, written atomically: everything
goes to a temporary sibling folder that replaces the output folder in one rename, so a
crash never leaves a half-written report.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from jinja2 import Environment, PackageLoader, select_autoescape

from ..errors import UserError
from ..files import default_mode
from ..grade import FLAGS
from ..interrupt import deferred
from ..results import RunResult, results_json
from ..schema import ResultsDoc
from .sections import collector, record_section, slug
from .tables import record_verdict, summary_table

MAX_FULL_RECORDS = 20  # "auto": above this, per-record sections keep one overview plot


@dataclass
class Extras:
    """Optional sections from the batch layer (regressions, history)."""

    regressions: list[dict] | None = None
    new: list[str] = field(default_factory=list)
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
    ctx = {
        "title": title, "doc": doc, "records": sections,
        "summary": summary_table(results, anchors), "extras": extras, "history": history,
        "n_failed": sum(not r.ok for r in results), "flag_legend": FLAGS,
        "verdicts": {v: sum(record_verdict(r) == v for r in results)
                     for v in ("ok", "warning", "unreliable", "failed")},
    }
    env = Environment(loader=PackageLoader("pipeline", "report/templates"),
                      autoescape=select_autoescape(["html.j2"]), trim_blocks=True,
                      lstrip_blocks=True)
    env.filters["mdcell"] = lambda s: str(s).replace("|", "\\|").replace("\n", " ")
    md = env.get_template("report.md.j2").render(**ctx)
    html = env.get_template("report.html.j2").render(**ctx)
    return md, html, files


#: What a run writes into its output folder; nothing else there is touched.
OUTPUTS = ("results.json", "report.md", "report.html", "plots")


def write_run(out_dir: Path, run: RunResult, doc: ResultsDoc, *, title: str,
              extras: Extras | None = None, markdown: bool = True, html: bool = True,
              plots_mode: str = "auto", mapper=map) -> Path:
    """Write results.json, report.md (+ plots/) and report.html into ``out_dir``.

    Everything is rendered into a temporary sibling folder first; a new ``out_dir`` is
    that folder renamed in one step. An existing ``out_dir`` keeps whatever else it holds
    (a history file, the user's notes): only :data:`OUTPUTS` are replaced, each by a
    rename, the report files last.
    """
    out_dir = Path(out_dir).resolve()
    if out_dir.exists() and not out_dir.is_dir():
        raise UserError(f"{out_dir}: exists and is not a folder; expected an output folder")
    md, page, files = render(run, doc, title=title, extras=extras, plots_mode=plots_mode,
                             mapper=mapper)
    tmp = None
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.tmp-", dir=out_dir.parent))
        os.chmod(tmp, default_mode(directory=True))  # mkdtemp makes it private
        (tmp / "results.json").write_text(results_json(doc), encoding="utf-8")
        if markdown:
            (tmp / "plots").mkdir()
            for name, png in files.items():
                (tmp / name).write_bytes(png)
            (tmp / "report.md").write_text(md, encoding="utf-8")
        if html:
            (tmp / "report.html").write_text(page, encoding="utf-8")
        with deferred():  # SIGTERM waits for these renames: never half a report
            if out_dir.exists():
                _replace_outputs(tmp, out_dir)
            else:
                os.replace(tmp, out_dir)
    except OSError as exc:
        raise UserError(f"{out_dir}: cannot write the report ({exc.strerror or exc})") from None
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
    return out_dir


def _replace_outputs(tmp: Path, out_dir: Path) -> None:
    """Move this run's outputs into an existing folder; stale ones of ours are removed."""
    old = Path(tempfile.mkdtemp(prefix=".old-", dir=tmp))
    for name in OUTPUTS:  # results.json first, the reports last
        src, dst = tmp / name, out_dir / name
        if dst.exists():
            os.replace(dst, old / name)
        if src.exists():
            os.replace(src, dst)
