"""One record's part of the report: its tables, the Recommended box and its figures.

:func:`record_section` is pure (a :class:`~pipeline.results.RecordResult` in, a template
context and PNG bytes out), so a process pool can render many records at once.
"""

from __future__ import annotations

import base64
import math
import re
from dataclasses import dataclass

import numpy as np

from ..grading import CRITERION_NAMES, criterion, ranked, static_map_note
from ..io import shown_source
from ..record import in_time_unit
from ..results import RecordResult
from ..schema import fit_label
from ..validate import event_simulation, validation_simulation
from . import plots
from .consistency_plots import consistency_figure, static_map_figure
from .controller import (
    RULE_TITLES,
    VERDICT_CLASS,
    margins_table,
    response_table,
    settings_table,
)
from .running_loop import running_loop_context
from .tables import (
    consistency_table,
    display_model,
    events_table,
    fmt,
    ident_summary_table,
    mse_unit,
    not_ok_rows,
    ranking_table,
    recommended_box,
)

ORDER_TITLES = {"first": "first-order models", "second": "second-order models",
                "nth": "n-th order models"}
#: A per-event table longer than this is folded (HTML ``<details>``) or cut to this many
#: rows with a pointer to results.json (Markdown): a 2000-event record stays readable.
FOLD_ROWS = 20
#: Identification events shown in full (ranking, plots); the others get one row each in
#: a compact table of their first-ranked models.
DETAILED_EVENTS = 5
#: Plot modes of a report (``report.plots``): everything, one overview per record, none.
MODES = ("full", "summary", "none")


@dataclass
class Figure:
    title: str
    png: bytes
    file: str = ""

    @property
    def b64(self) -> str:
        return base64.b64encode(self.png).decode("ascii")


def slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "record"


def collector(files: dict[str, bytes]):
    """``add(stem, title, png) -> Figure`` that also keeps the PNG for the Markdown report."""
    def add(stem: str, fig_title: str, png: bytes) -> Figure:
        name = f"plots/{slug(stem)}.png"
        files[name] = png
        return Figure(fig_title, png, name)

    return add


def record_section(res: RecordResult, mode: str, anchor: str) -> tuple[dict, dict[str, bytes]]:
    """One record's template context and its PNG files (pure; runs in a worker process
    when the report is rendered in parallel). ``mode`` is one of :data:`MODES`."""
    files: dict[str, bytes] = {}
    dpi = plots.SUMMARY_DPI if mode == "summary" else plots.DPI  # many records: lighter
    add = collector(files)
    rec = res.record
    ctx = {"name": res.name, "anchor": anchor, "ok": res.ok, "error": res.error,
           "source": shown_source(rec.source if rec else res.source),
           "notes": list(rec.notes) if rec else [], "events": None, "ident": [],
           "box": None, "ident_rest": None, "events_line": "", "record_flags": [],
           "controller": None, "compare": None, "running_loop": None}
    if rec is None:
        return ctx, files
    tu = rec.units.get("time")
    median, jitter = rec.sampling()
    ctx["meta"] = {"samples": rec.n_samples,
                   "sample_time": (f"{fmt(in_time_unit(rec.sample_time, tu))} {tu or 's'}"
                                   if rec.sample_time else "irregular" if median is None else
                                   f"irregular (median {fmt(in_time_unit(median, tu))} "
                                   f"{tu or 's'}, jitter {100 * (jitter or 0):.2g} %)"),
                   "input": rec.input_name, "output": rec.output_name,
                   "units": ", ".join(f"{k}: {v}" for k, v in rec.units.items()) or "-"}
    ctx["box"] = recommended_box(res)
    if mode == "full":
        ctx["compare"] = _compare(res, add, anchor, dpi)
    ctx["controller"] = controller_context(res, mode, add, anchor, dpi)
    ctx["running_loop"] = running_loop_context(res.loop, rec.units, res.recommended)
    ctx["record_flags"] = [{"code": f.code, "message": f.message, "severity": f.severity}
                           for f in res.flags]
    ctx["events"] = events_table(res)
    ctx["events_line"] = events_line(res)
    if res.events and mode != "none":
        ctx["overview"] = add(f"{anchor}_overview", "Record with events",
                              plots.overview(rec, res.events, res.roles, dpi=dpi))
    ctx["consistency"] = _consistency_context(res, mode, add, anchor, dpi)
    ident = res.identification_events
    for i in ident[:DETAILED_EVENTS]:
        ctx["ident"].append(_ident_context(res, i, mode, add, anchor, dpi))
    if len(ident) > DETAILED_EVENTS:
        ctx["ident_rest"] = ident_summary_table(res, ident[DETAILED_EVENTS:])
    return ctx, files


def compare_curve(res: RecordResult) -> tuple[slice, np.ndarray, float] | None:
    """The recommended model simulated over every event (as the validation simulates a
    run: continuously, from the operating point before it), the samples it covers and
    its fit % there (``100 (1 - |y - yhat| / |y - mean y|)``, MATLAB ``compare``'s
    NRMSE fit); None without a recommended model."""
    f, rec = res.recommended, res.record
    if f is None or rec is None or not res.events:
        return None
    sims = validation_simulation(f.model, rec, res.events, list(range(len(res.events))),
                                 f.balance_point)
    if not sims:
        return None
    lo, hi = min(sl.start for sl, _ in sims), max(sl.stop for sl, _ in sims)
    yhat = np.full(hi - lo, np.nan)
    for sl, sim in sims:
        yhat[sl.start - lo:sl.stop - lo] = sim
    y = rec.y[lo:hi]
    ok = np.isfinite(yhat)
    spread = float(np.linalg.norm(y[ok] - np.mean(y[ok]))) if ok.any() else 0.0
    fit = 100.0 * (1.0 - float(np.linalg.norm(y[ok] - yhat[ok])) / spread) if spread > 0 \
        else math.nan
    return slice(lo, hi), yhat, fit


def _compare(res: RecordResult, add, anchor: str, dpi: int):
    got = compare_curve(res)
    if got is None:
        return None
    sl, yhat, fit = got
    f = res.recommended
    return add(f"{anchor}_compare", "Compare", plots.compare(
        res.record, sl, yhat, f"{_label(f)}: {display_model(f, res.record).text(3)}", fit,
        events=res.events,
        roles=res.roles, dpi=dpi))


def events_line(res: RecordResult) -> str:
    """``2000 events: 1990 steps, 10 impulses; 1 identification, 1999 validation``."""
    if not res.events:
        return ""
    kinds: dict[str, int] = {}
    for e in res.events:
        kinds[e.kind] = kinds.get(e.kind, 0) + 1
    roles: dict[str, int] = {}
    for e in res.events:
        role = res.roles.get(e.index, "unused")
        roles[role] = roles.get(role, 0) + 1
    return (f"{len(res.events)} event(s): "
            + ", ".join(f"{n} {k}{'s' if n > 1 else ''}" for k, n in kinds.items()) + "; "
            + ", ".join(f"{n} {r}" for r, n in roles.items()))


def _consistency_context(res: RecordResult, mode: str, add, anchor: str, dpi: int
                         ) -> dict | None:
    table = consistency_table(res)
    if table is None:
        return None
    rec, c = res.record, res.consistency
    out = {"table": table, "note": static_map_note(c.static_map, rec.units), "figures": []}
    if mode == "full":
        out["figures"].append(add(f"{anchor}_consistency", "Each step on its own",
                                  consistency_figure(list(c.estimates), rec.units, dpi=dpi)))
        if c.static_map is not None:
            out["figures"].append(add(f"{anchor}_static_map", "Static map",
                                      static_map_figure(c.static_map, rec.units, dpi=dpi)))
    return out


def _label(f) -> str:
    return fit_label(f.method, f.event, list(f.events))


def _heavy(res: RecordResult, event: int) -> str | None:
    """The curve label of the recommended model on the overlays of ``event``'s fits
    (drawn heavier), None on another event's (a label does not name the event: the same
    method's fit on another event has the same one)."""
    f = res.recommended
    return _label(f) if f is not None and f.event == event else None


def _marks(diag: dict) -> list[tuple[float, float, str]]:
    """The points a method read (t63/y63, ...) for drawing."""
    out = []
    for k, v in diag.items():
        yk = "y" + k[1:]
        if k.startswith("t") and yk in diag and isinstance(v, int | float) and \
                isinstance(diag[yk], int | float):
            out.append((float(v), float(diag[yk]), k))
    return out


def _ident_context(res: RecordResult, i: int, mode: str, add, anchor: str, dpi: int
                   ) -> dict:
    rec, ev = res.record, res.events[i]
    validation = res.validation_events
    fits, crit = ranked(res, i), criterion(res)
    out = {"index": i, "kind": ev.kind, "table": ranking_table(res, i),
           "other": not_ok_rows(res, i), "criterion": CRITERION_NAMES[crit],
           "figures": []}
    if not fits or mode in ("summary", "none"):
        return out
    values = [f.metrics.get(crit, math.nan) for f in fits]
    if crit == "aic":  # differences from the lowest: an AIC's level means nothing
        low = min((v for v in values if math.isfinite(v)), default=0.0)
        values, label = [v - low for v in values], "AIC - lowest AIC"
    else:
        unit = mse_unit(rec, crit)
        label = CRITERION_NAMES[crit] + (f" [{unit}]" if unit else "")
    out["figures"].append(add(f"{anchor}_e{i}_ranking", "Methods ranked", plots.criterion_bars(
        [f.method for f in fits], values, label,
        f"Event {i}: methods ranked by {out['criterion']} (lower is better)", dpi=dpi)))
    sl = slice(ev.i_start, ev.i_end)
    groups: dict[str, list] = {}
    for f in fits:
        groups.setdefault(f.model.order_class, []).append(f)
    for order in sorted(groups, key=list(ORDER_TITLES).index):
        fits = groups[order]
        label = ORDER_TITLES.get(order, "best model")
        curves = [(f"{_label(f)}: {f.model.text(3)}", event_simulation(f.model, rec, ev))
                  for f in fits]
        marks = _marks(fits[0].diagnostics) if order == "first" else []
        out["figures"].append(add(
            f"{anchor}_e{i}_ident_{order}", f"Identification event {i}: {label}",
            plots.overlay(rec, sl, curves, f"Identification event {i}: measured vs {label}",
                          marks=marks, heavy=_heavy(res, i), dpi=dpi)))
        if validation:
            out["figures"].append(add(
                f"{anchor}_e{i}_valid_{order}", f"Validation events: {label}",
                _validation_overlay(res, fits, validation, label, dpi, _heavy(res, i))))
    return out


def _validation_overlay(res: RecordResult, fits, validation, label, dpi: int,
                        heavy: str | None = None) -> bytes:
    rec = res.record
    lo = min(res.events[v].i_start for v in validation)
    hi = max(res.events[v].i_end for v in validation)

    def curves():  # one at a time (plots.overlay decimates each as it comes)
        for f in fits:
            sims = validation_simulation(f.model, rec, res.events, validation,
                                         f.balance_point)
            if len(sims) == 1 and sims[0][0] == slice(lo, hi):
                y = sims[0][1]  # one run over the whole span: the curve itself
            else:
                y = np.full(hi - lo, np.nan)
                for sl, sim in sims:
                    y[sl.start - lo : sl.stop - lo] = sim
                sim = None  # the last run's simulation, before the next fit's is made
            del sims
            yield f"{_label(f)} (MSE {fmt(f.metrics.get('mse_validation'), 3)})", y
            del y  # before the next curve is allocated

    return plots.overlay(rec, slice(lo, hi), curves(),
                         f"Validation: measured vs {label}, simulated from each run's "
                         "operating point", events=res.events, roles=res.roles,
                         heavy=heavy, dpi=dpi)


def controller_context(res: RecordResult, mode: str, add, anchor: str, dpi: int
                       ) -> dict | None:
    """The Controller section's template context (None when nothing was tuned)."""
    rt = res.tuning
    if rt is None:
        return None
    out = {"rule": RULE_TITLES.get(rt.rule, rt.rule), "method": rt.method,
           "ok": rt.ok, "reason": rt.reason, "figure": None}
    if not rt.ok:
        return out
    t = rt.tuning
    st = t.settings
    red = st.reduced
    out.update({
        "kind": t.controller.kind, "verdict": t.verdict,
        "verdict_class": VERDICT_CLASS[t.verdict], "reasons": list(t.reasons),
        "action": (f"{t.action} acting (the process gain is "
                   f"{'positive' if t.model.K > 0 else 'negative'})"),
        "settings": settings_table(rt), "margins": margins_table(t),
        "response": response_table(t, rt.units),
        "percent": (f"gain {fmt(t.percent_gain, 4)} %/% (spans: input "
                    f"{fmt(t.options.input_span)}, output {fmt(t.options.output_span)})"
                    if t.percent_gain is not None else ""),
        "tau_c": (f"tau_c = {fmt(st.tau_c, 4)} s" if st.tau_c else ""),
        "reduced": (f"{red.kind.replace('_', ' ')}: {red.model().text()}"
                    + (f" ({'; '.join(red.steps)})" if red.steps else "")),
        "notes": list(t.notes),
    })
    if mode == "full" and t.response is not None:  # summary: one overview per record
        out["figure"] = add(f"{anchor}_controller", "Tuned loop",
                            plots.loop_figure(t, rt.units, dpi))
    return out
