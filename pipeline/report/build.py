"""Report assembly: results -> a template context -> report.md (+ PNGs), report.html
(one self-contained file, plots inline) and results.json, written atomically: everything
goes to a temporary sibling folder that replaces the output folder in one rename, so a
crash never leaves a half-written report.
"""

from __future__ import annotations

import base64
import math
import os
import re
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from jinja2 import Environment, PackageLoader, select_autoescape

from ..errors import UserError
from ..methods import REGISTRY
from ..results import RecordResult, RunResult, results_json
from ..schema import ResultsDoc
from ..validate import event_simulation, validation_simulation
from . import plots
from .tables import fmt, params_text, summary_rows

ORDER_TITLES = {"first": "first-order models", "second": "second-order models",
                "nth": "n-th order models"}
MAX_FULL_RECORDS = 20  # "auto": above this, per-record sections keep one overview plot


@dataclass
class Figure:
    title: str
    png: bytes
    file: str = ""

    @property
    def b64(self) -> str:
        return base64.b64encode(self.png).decode("ascii")


@dataclass
class Extras:
    """Optional sections from the batch layer (regressions, history)."""

    regressions: list[dict] | None = None
    new: list[str] = field(default_factory=list)
    history: list[tuple[str, bytes]] = field(default_factory=list)


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "record"


def _marks(diag: dict) -> list[tuple[float, float, str]]:
    out = []
    for k, v in diag.items():
        yk = "y" + k[1:]
        if k.startswith("t") and yk in diag and isinstance(v, int | float) and \
                isinstance(diag[yk], int | float):
            out.append((float(v), float(diag[yk]), k))
    return out


def unique_anchors(names: list[str]) -> list[str]:
    """HTML anchors and plot-file stems, unique even where two names slug alike."""
    out, used = [], set()
    for name in names:
        base = a = _slug(name)
        k = 1
        while a in used:
            k += 1
            a = f"{base}-{k}"
        used.add(a)
        out.append(a)
    return out


def _record_context(res: RecordResult, mode: str, add, anchor: str) -> dict:
    rec = res.record
    ctx = {"name": res.name, "anchor": anchor, "ok": res.ok,
           "error": res.error, "source": rec.source if rec else res.source,
           "notes": list(rec.notes) if rec else [], "events": [], "ident": []}
    if rec is None:
        return ctx
    ctx["meta"] = {"samples": rec.n_samples, "sample_time": fmt(rec.sample_time),
                   "input": rec.input_name, "output": rec.output_name,
                   "units": ", ".join(f"{k}: {v}" for k, v in rec.units.items()) or "-"}
    ctx["events"] = [{
        "index": e.index, "kind": e.kind, "role": res.roles.get(e.index, "-"),
        "t0": fmt(e.t0), "t_end": fmt(e.t_end), "u0": fmt(e.u0),
        "u_ss": fmt(e.u_ss) if e.kind == "step" else "-",
        "area": fmt(e.area) if e.kind == "impulse" else "-",
        "y0": fmt(e.y0), "y_ss": fmt(e.y_ss), "settled": "yes" if e.settled else "NO (short)",
    } for e in res.events]
    if res.events and mode != "none":
        ctx["overview"] = add(f"{ctx['anchor']}_overview",
                              "Record with events", plots.overview(rec, res.events, res.roles))
    validation = res.validation_events
    for i in res.identification_events:
        ctx["ident"].append(_ident_context(res, i, validation, mode, add, ctx["anchor"]))
    return ctx


def _ident_context(res: RecordResult, i: int, validation: list[int], mode: str, add,
                   anchor: str) -> dict:
    rec, ev = res.record, res.events[i]
    ranked = res.ranking(i)
    crit = "mse_validation" if validation else "ise"
    rows = []
    for rank, f in enumerate(ranked, start=1):
        m = f.metrics
        rows.append({"rank": rank, "method": f.method, "title": REGISTRY[f.method].title,
                     "params": params_text(f.model.params, rec.units, f.model.structure),
                     "tf": f.model.text(),
                     "ise": fmt(m.get("ise")), "mse_id": fmt(m.get("mse_identification")),
                     "mse_val": fmt(m.get("mse_validation")), "fit": fmt(m.get("fit_percent"), 3),
                     "source": REGISTRY[f.method].citation})
    other = [{"method": f.method, "status": f.status, "reason": f.reason}
             for f in res.fits if f.event == i and not f.ok]
    out = {"index": i, "kind": ev.kind, "rows": rows, "other": other,
           "criterion": "validation MSE" if validation else "ISE on the identification event",
           "figures": []}
    if not ranked or mode in ("summary", "none"):
        return out
    unit = rec.units.get("output")
    sq = f" [{unit}^2]" if unit else ""
    out["figures"].append(add(f"{anchor}_e{i}_ranking", "Methods ranked", plots.criterion_bars(
        [f.method for f in ranked], [f.metrics.get(crit, math.nan) for f in ranked],
        f"{'validation MSE' if validation else 'ISE'}{sq if validation else ''}",
        f"Event {i}: methods ranked by {out['criterion']} (lower is better)")))
    sl = slice(ev.i_start, ev.i_end)
    groups = {}
    for f in ranked:
        groups.setdefault(f.model.order_class, []).append(f)
    for order in sorted(groups, key=list(ORDER_TITLES).index):
        fits = groups[order]
        label = ORDER_TITLES.get(order, "best model")
        curves = [(f"{f.method}: {f.model.text(3)}", event_simulation(f.model, rec, ev))
                  for f in fits]
        marks = _marks(fits[0].diagnostics) if order == "first" else []
        out["figures"].append(add(
            f"{anchor}_e{i}_ident_{order}", f"Identification event {i}: {label}",
            plots.overlay(rec, sl, curves, f"Identification event {i}: measured vs {label}",
                          marks=marks)))
        if validation:
            out["figures"].append(add(
                f"{anchor}_e{i}_valid_{order}", f"Validation events: {label}",
                _validation_overlay(res, fits, validation, label)))
    return out


def _validation_overlay(res: RecordResult, fits, validation, label) -> bytes:
    rec = res.record
    lo = min(res.events[v].i_start for v in validation)
    hi = max(res.events[v].i_end for v in validation)
    curves = []
    for f in fits:
        y = np.full(hi - lo, np.nan)
        for sl, sim in validation_simulation(f.model, rec, res.events, validation):
            y[sl.start - lo : sl.stop - lo] = sim
        curves.append((f"{f.method} (MSE {fmt(f.metrics.get('mse_validation'), 3)})", y))
    return plots.overlay(rec, slice(lo, hi), curves,
                         f"Validation: measured vs {label}, simulated from each run's "
                         "operating point", events=res.events, roles=res.roles)


def _collector(files: dict[str, bytes]):
    def add(stem: str, fig_title: str, png: bytes) -> Figure:
        name = f"plots/{_slug(stem)}.png"
        files[name] = png
        return Figure(fig_title, png, name)

    return add


def record_section(res: RecordResult, mode: str, anchor: str) -> tuple[dict, dict[str, bytes]]:
    """One record's template context and its PNG files (pure; runs in a worker process
    when the report is rendered in parallel)."""
    files: dict[str, bytes] = {}
    dpi = plots.DPI
    if mode == "summary":
        plots.DPI = plots.SUMMARY_DPI  # many records: smaller images, a lighter HTML file
    try:
        return _record_context(res, mode, _collector(files), anchor), files
    finally:
        plots.DPI = dpi


def render(run: RunResult, doc: ResultsDoc, *, title: str, extras: Extras | None = None,
           plots_mode: str = "auto", mapper=map) -> tuple[str, str, dict[str, bytes]]:
    """``(markdown, html, {png file name: bytes})`` for a run.

    ``plots_mode``: "full" (overview, ranking bars and the overlay views per record),
    "summary" (one overview per record), "none" (tables only), "auto" (full up to
    :data:`MAX_FULL_RECORDS` records, else summary). ``mapper`` maps
    :func:`record_section` over the records (``map``, or a process pool's ``map``).
    """
    files: dict[str, bytes] = {}
    add = _collector(files)
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
        "summary": summary_rows(results, anchors), "extras": extras, "history": history,
        "n_failed": sum(not r.ok for r in results),
    }
    env = Environment(loader=PackageLoader("pipeline", "report/templates"),
                      autoescape=select_autoescape(["html.j2"]), trim_blocks=True,
                      lstrip_blocks=True)
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
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    if out_dir.exists() and not out_dir.is_dir():
        raise UserError(f"{out_dir}: exists and is not a folder; expected an output folder")
    md, page, files = render(run, doc, title=title, extras=extras, plots_mode=plots_mode,
                             mapper=mapper)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.tmp-", dir=out_dir.parent))
    try:
        (tmp / "results.json").write_text(results_json(doc), encoding="utf-8")
        if markdown:
            (tmp / "plots").mkdir()
            for name, png in files.items():
                (tmp / name).write_bytes(png)
            (tmp / "report.md").write_text(md, encoding="utf-8")
        if html:
            (tmp / "report.html").write_text(page, encoding="utf-8")
        if out_dir.exists():
            _replace_outputs(tmp, out_dir)
        else:
            os.replace(tmp, out_dir)
    except OSError as exc:
        raise UserError(f"{out_dir}: cannot write the report ({exc})") from None
    finally:
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
