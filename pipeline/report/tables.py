"""The report's tables and its Recommended box, built once from the results: the Markdown
and the HTML report render the same :class:`Table` objects, and the terminal prints them.

Number formats, labels, units and the parameter order come from the parameter table
(:data:`pipeline.models.PARAMETERS`); method titles and publications from the registry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..fit import Fit
from ..grading import CRITERION_COLUMNS, CRITERION_NAMES, criterion, ranked, record_verdict
from ..methods import REGISTRY
from ..models import PARAMETERS, STRUCTURES, ProcessModel
from ..record import Record, in_time_unit
from ..results import UNBOUNDED, RecordResult
from ..schema import fit_label


@dataclass(frozen=True)
class Cell:
    """One table cell: ``kind`` "text", "num", "code" (monospace) or "verdict" (a badge);
    ``href`` makes it a link (an anchor in the report)."""

    text: str
    kind: str = "text"
    href: str | None = None
    note: str = ""  # a smaller second line (HTML) / parenthesis (Markdown)


@dataclass(frozen=True)
class Table:
    columns: list[str]
    rows: list[list[Cell]] = field(default_factory=list)
    highlight: int | None = None  # the row of the answer (the recommended model)


# -- numbers -----------------------------------------------------------------------------

def fmt(v, digits: int = 4) -> str:
    """A number for a table cell ("-" for missing or non-finite)."""
    if v is None:
        return "-"
    if isinstance(v, float):
        if not math.isfinite(v):
            return "-"
        return f"{v:.{digits}g}"
    return str(v)


def _ordered(params: dict) -> list[str]:
    order = list(PARAMETERS)
    return sorted(params, key=lambda k: order.index(k) if k in order else len(order))


def shown(name: str, value, units: dict | None, structure: str | None):
    """A parameter value (seconds-based, as the models hold it) in the user's time unit
    ``units["time"]``: times scale with it, rates (frequencies, an integrator's gain)
    against it."""
    if value is None or name not in PARAMETERS or not units or not units.get("time"):
        return value
    integrating = bool(structure and structure in STRUCTURES and STRUCTURES[structure].integrating)
    power = PARAMETERS[name].time_power(integrating)
    one = in_time_unit(1.0, units["time"])  # one second in the user's unit
    return float(value) * one**power if power else value


def shown_params(params: dict, units: dict | None, structure: str | None) -> dict:
    return {k: shown(k, v, units, structure) for k, v in params.items()}


def params_text(params: dict | None, units: dict | None = None,
                structure: str | None = None) -> str:
    """``K=20.7 degC/V, T=55.4 s, delay=3.64 s`` in the parameter table's order and formats
    (in the user's units when ``units`` are given; a zero dead time is left out)."""
    if not params:
        return "-"
    params = shown_params(params, units, structure)
    out = []
    for k in _ordered(params):
        if k == "delay" and float(params[k]) == 0.0:
            continue
        u = _unit(k, units, structure) if units is not None else ""
        out.append(f"{k}={_value(k, params[k])}" + (f" {u}" if u else ""))
    return ", ".join(out)


def _value(name: str, v) -> str:
    return PARAMETERS[name].format(v) if name in PARAMETERS else fmt(float(v))


def _unit(name: str, units: dict | None, structure: str | None) -> str:
    if name not in PARAMETERS:
        return ""
    integrating = bool(structure and structure in STRUCTURES and STRUCTURES[structure].integrating)
    return PARAMETERS[name].unit(units or {}, integrating=integrating)


def unit_of(name: str, record: Record | None, structure: str | None) -> str:
    """The unit of parameter ``name`` for this record (K per time unit for integrators)."""
    return _unit(name, record.units if record else {}, structure)


#: The ranking's parameter column: values with their 95 % intervals (:func:`with_ci`).
PARAMETERS_COLUMN = "parameters (± 95 % half-width)"
#: An interval whose two sides differ by more than this share is shown as [low, high], not
#: as a half-width (a log-scale interval of a poorly determined lag is lopsided).
ASYMMETRIC = 0.25


def with_ci(fit: Fit, name: str, record: Record | None = None) -> str:
    """The value with its 95 % interval (in the record's units): ``value ± half-width``
    (the 95 % half-width, two significant digits, the value rounded to the same place), or
    ``value [low, high]`` when the interval is lopsided (:data:`ASYMMETRIC`)."""
    units, st = (record.units if record else None), fit.model.structure
    v = shown(name, float(fit.model.params[name]), units, st)
    ci = fit.ci95.get(name)
    if not ci or name == "n":  # an order is snapped to an integer: no interval on it
        return _value(name, v)
    if not all(b is not None and math.isfinite(b) and abs(b) <= UNBOUNDED for b in ci):
        return f"{_value(name, v)} (unbounded)"
    lo, hi = sorted((shown(name, float(ci[0]), units, st), shown(name, float(ci[1]), units, st)))
    if lopsided(v, lo, hi):
        return f"{_value(name, v)} [{fmt(lo, 3)}, {fmt(hi, 3)}]"
    half = (hi - lo) / 2
    return f"{_rounded_to(v, half)} ± {fmt(half, 2)}"


def lopsided(v: float, lo: float, hi: float) -> bool:
    """Whether ``[lo, hi]`` is not about symmetric about ``v`` (its sides differ by more
    than :data:`ASYMMETRIC`, or ``v`` is outside it): shown as its ends, not ``±``."""
    below, above = v - lo, hi - v
    return below < 0 or above < 0 or abs(above - below) > ASYMMETRIC * max(above, below)


def interval_text(v: float, lo: float, hi: float) -> str:
    """``[lo, hi]`` to the decimal place :func:`with_ci` rounds the value to: the second
    significant digit of the half-width where the interval is about symmetric about
    ``v`` (issue 27 item 9: K 2.00000 ± 0.00012 read "[2, 2]" at four significant
    digits; a zero's 59 ± 12 read "[46.54, 70.68]"), three significant digits where it
    is lopsided (:data:`ASYMMETRIC`)."""
    if lopsided(v, lo, hi):
        return f"[{fmt(lo, 3)}, {fmt(hi, 3)}]"
    half = (hi - lo) / 2
    return f"[{_rounded_to(lo, half)}, {_rounded_to(hi, half)}]"


def _rounded_to(v: float, half: float) -> str:
    """``v`` to the decimal place of ``half``'s second significant digit (21.2234 with a
    half-width of 0.53 is 21.22; 58.61 with 12 is 59); as is when ``half`` is 0."""
    if not (half > 0 and math.isfinite(half)):
        return fmt(v)
    place = math.floor(math.log10(half)) - 1
    if place >= 0:
        return f"{round(v, -place):.0f}"
    return f"{v:.{-place}f}"


def display_model(fit: Fit, record: Record | None):
    """The fit's model with its parameters in the user's time unit (so its transfer
    function reads in that unit's s)."""
    units = record.units if record else None
    return ProcessModel(fit.model.structure,
                        shown_params(fit.model.params, units, fit.model.structure))


def dynamics_text(structure: str | None, params: dict, record: Record | None = None) -> str:
    """The dynamic parameters of a model (the structure table says which they are), with
    their units when the record is given."""
    if not structure or structure not in STRUCTURES:
        return "-"
    names = STRUCTURES[structure].dynamics
    params = shown_params(params, record.units if record is not None else None, structure)
    return ", ".join(f"{k}={_value(k, params[k])}" + (
        f" {u}" if record is not None and (u := unit_of(k, record, structure)) else "")
        for k in names if k in params) or "-"


def mse_unit(record: Record | None, crit: str = "mse_validation") -> str:
    """The unit of a squared-error criterion: the output's unit squared (``degC^2``), or
    "" when the output has no unit or the criterion is no MSE (AIC)."""
    unit = record.units.get("output") if record is not None else None
    return f"{unit}^2" if unit and crit.startswith("mse") else ""


def with_mse_unit(value, record: Record | None, crit: str = "mse_validation") -> str:
    """``fmt(value)`` with :func:`mse_unit` after it (issue 29: "validation MSE 16.1" read
    as a bare number)."""
    text = fmt(value)
    unit = mse_unit(record, crit)
    return f"{text} {unit}" if unit and text != "-" else text


# -- tables ------------------------------------------------------------------------------

def summary_table(results: list[RecordResult], anchors: list[str]) -> Table:
    """One row per record: its verdict, events and the model to use."""
    t = Table(["record", "verdict", "events", "model", "K", "dynamics", "delay",
               "validation MSE", "fit %"])
    for r, anchor in zip(results, anchors, strict=True):
        fit = r.recommended
        verdict = record_verdict(r)
        if fit is None:
            t.rows.append([Cell(r.name, href=f"#{anchor}"),
                           Cell(verdict, "verdict", note=r.error or "no model"),
                           Cell(str(len(r.events)), "num")] + [Cell("-")] * 6)
            continue
        p = fit.model.params
        t.rows.append([
            Cell(r.name, href=f"#{anchor}"), Cell(verdict, "verdict"),
            Cell(str(len(r.events)), "num"), Cell(fit.method, "code"),
            Cell(f"{with_ci(fit, 'K', r.record)} "
                 f"{unit_of('K', r.record, fit.model.structure)}".strip(), "num"),
            Cell(dynamics_text(fit.model.structure, p, r.record)),
            Cell(f"{fmt(shown('delay', fit.model.delay, r.record.units, None))} "
                 f"{unit_of('delay', r.record, None)}".strip(), "num"),
            Cell(with_mse_unit(fit.metrics.get("mse_validation"), r.record), "num"),
            Cell(fmt(fit.metrics.get("fit_percent"), 3), "num"),
        ])
    return t


def events_table(res: RecordResult) -> Table:
    tu = res.record.units.get("time") if res.record else None
    t = Table(["#", "kind", "role", f"t0 [{tu or 's'}]", f"t_end [{tu or 's'}]", "u0", "u_ss",
               "area", "y0", "y_ss", "response", "settled"])
    for e in res.events:
        t.rows.append([
            Cell(str(e.index), "num"), Cell(e.kind), Cell(res.roles.get(e.index, "-")),
            Cell(fmt(in_time_unit(e.t0, tu)), "num"), Cell(fmt(in_time_unit(e.t_end, tu)), "num"),
            Cell(fmt(e.u0), "num"),
            Cell(fmt(e.u_ss) if e.kind == "step" else "-", "num"),
            Cell(fmt(e.area) if e.kind == "impulse" else "-", "num"),
            Cell(fmt(e.y0), "num"), Cell(fmt(e.y_ss), "num"),
            Cell(response_text(e, res.record)),
            Cell("yes" if e.settled else "NO (still moving)")])
    return t


def response_text(e, record: Record | None) -> str:
    """"settling", or "ramp 0.5 cm/s" / "level shift" for an integrating response."""
    if e.response == "ramp":
        units = record.units if record else {}
        per = f" {units.get('output', '')}/{units.get('time', 's')}".rstrip("/ ")
        return f"ramp {fmt(e.slope, 3)}{per if units.get('output') else ''}"
    return e.response.replace("_", " ")


def ranking_table(res: RecordResult, event: int) -> Table:
    """The ok fits of one identification event in the order of the criterion the
    recommendation decided by (:func:`pipeline.grading.ranked`), with their verdicts; the
    recommended fit's row is marked (it need not be the first: a simpler structure within
    the uncertainty wins)."""
    crit = criterion(res)
    unit = mse_unit(res.record, crit)
    name = CRITERION_COLUMNS[crit] + (f" [{unit}]" if unit else "")
    fits, chosen = ranked(res, event), res.recommended
    t = Table(["rank", "method", "verdict", PARAMETERS_COLUMN, "transfer function", name,
               "ISE (ident.)", "fit % (valid.)", "reference"],
              highlight=next((k for k, f in enumerate(fits) if f is chosen), None))
    for rank, f in enumerate(fits, start=1):
        m, info = f.metrics, REGISTRY.get(f.method)
        title = info.title if info else ""
        if f is chosen:
            title = f"recommended · {title}" if title else "recommended"
        t.rows.append([
            Cell(str(rank), "num"),
            Cell(fit_label(f.method, f.event, list(f.events)), "code", note=title),
            Cell(f.verdict or "-", "verdict", note=", ".join(x.code for x in f.flags)),
            Cell(", ".join(f"{k}={with_ci(f, k, res.record)}" for k in _ordered(f.model.params)
                           if not (k == "delay" and f.model.delay == 0.0))),
            Cell(display_model(f, res.record).text(), "code"), Cell(fmt(m.get(crit)), "num"),
            Cell(fmt(m.get("ise")), "num"), Cell(fmt(m.get("fit_percent"), 3), "num"),
            Cell(info.citation if info else "", note="")])
    return t


def ident_summary_table(res: RecordResult, events: list[int]) -> Table:
    """One row per identification event: its first-ranked model by the record's criterion
    (a long record's compact view of the events beyond the detailed ones)."""
    crit = criterion(res)
    t = Table(["event", "kind", "first ranked", "verdict", "parameters",
               CRITERION_COLUMNS[crit], "ok fits"])
    for i in events:
        fits = ranked(res, i)
        kind = res.events[i].kind if i < len(res.events) else "-"
        if not fits:
            t.rows.append([Cell(str(i), "num"), Cell(kind), Cell("-"), Cell("-"),
                           Cell("no model"), Cell("-"), Cell("0", "num")])
            continue
        f = fits[0]
        t.rows.append([
            Cell(str(i), "num"), Cell(kind),
            Cell(fit_label(f.method, f.event, list(f.events)), "code",
                 note="recommended" if f is res.recommended else ""),
            Cell(f.verdict or "-", "verdict"),
            Cell(params_text(f.model.params, res.record.units if res.record else None,
                             f.model.structure)),
            Cell(fmt(f.metrics.get(crit)), "num"), Cell(str(len(fits)), "num")])
    return t


def scores_text(res: RecordResult, fit: Fit) -> str:
    """How the recommended model scored, in words: the criterion it was chosen by, and
    its validation fit where there are validation events."""
    crit = criterion(res)
    text = f"{CRITERION_NAMES[crit]} {with_mse_unit(fit.metrics.get(crit), res.record, crit)}"
    if res.validation_events and crit != "mse_validation":
        text += f", validation MSE {with_mse_unit(fit.metrics.get('mse_validation'), res.record)}"
    if res.validation_events:
        text = f"validation fit {fmt(fit.metrics.get('fit_percent'), 3)} %, " + text
    return text


def recommended_box(res: RecordResult) -> dict | None:
    """What the report's first box shows: the model with units and intervals, its fit, the
    verdict and every flag in plain words, and why it was chosen."""
    fit = res.recommended
    if fit is None:
        return None
    rec, st = res.record, fit.model.structure
    rows = Table(["parameter", "value (± 95 % half-width)", "unit", "95 % interval"])
    for k in _ordered(fit.model.params):
        ci = fit.ci95.get(k)
        interval = (f"[{fmt(ci[0])}, {fmt(ci[1])}]" if ci and None not in ci else "-")
        label = PARAMETERS[k].label if k in PARAMETERS else k
        units = rec.units if rec else None
        if ci and None not in ci and all(abs(b) <= UNBOUNDED for b in ci) and k != "n":
            lo, hi = sorted((shown(k, ci[0], units, st), shown(k, ci[1], units, st)))
            interval = interval_text(shown(k, float(fit.model.params[k]), units, st), lo, hi)
        elif ci and k != "n":
            interval = "unbounded"
        rows.rows.append([Cell(label), Cell(with_ci(fit, k, rec), "num"),
                          Cell(unit_of(k, rec, st)), Cell(interval, "num")])
    info = REGISTRY.get(fit.method)
    flags = list(fit.flags) + [f for f in res.flags if f not in fit.flags]
    units = ", ".join(f"{k} in {unit_of(k, rec, st)}" for k in _ordered(fit.model.params)
                      if unit_of(k, rec, st))
    return {
        "method": fit.method, "title": info.title if info else fit.method,
        "citation": info.citation if info else "", "event": fit.event,
        "structure": STRUCTURES[st].formula, "tf": display_model(fit, rec).text(),
        "units": units,
        "params": rows, "scores": scores_text(res, fit),
        "verdict": record_verdict(res),
        "flags": [{"code": f.code, "message": f.message, "severity": f.severity}
                  for f in flags],
        "reason": res.recommendation.reason,
    }


def not_ok_rows(res: RecordResult, event: int) -> list[dict]:
    return [{"method": f.method, "status": f.status, "reason": f.reason}
            for f in res.fits if f.event == event and not f.ok]


def consistency_table(res: RecordResult) -> Table | None:
    """Each step on its own: levels, gain and dominant time constant with intervals."""
    c = res.consistency
    if c is None or not c.estimates:
        return None
    rec = res.record
    tu = rec.units.get("time") if rec else None
    k_unit = unit_of("K", rec, "first_order")
    t = Table(["event", f"t0 [{tu or 's'}]", "input", "K" + (f" [{k_unit}]" if k_unit else ""),
               f"T (dominant) [{tu or 's'}]", "initial state"])
    for e in c.estimates:
        half_k = (e.K_ci[1] - e.K_ci[0]) / 2
        T, half_t = in_time_unit(e.T, tu), in_time_unit((e.T_ci[1] - e.T_ci[0]) / 2, tu)
        t.rows.append([Cell(str(e.index), "num"), Cell(fmt(in_time_unit(e.t0, tu)), "num"),
                       Cell(f"{fmt(e.u0)} -> {fmt(e.u1)}"),
                       Cell(f"{fmt(e.K)} ± {fmt(half_k, 2)}", "num"),
                       Cell(f"{fmt(T)} ± {fmt(half_t, 2)}", "num"), Cell(e.state)])
    return t
