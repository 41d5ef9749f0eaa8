"""The report's Controller section as tables and lines (no matplotlib: ``identify``
prints :func:`controller_lines`): the settings tuned from the recommended model, in the
controller's form and units, the margins, the worst case over the model's intervals and
the tuned loop's responses (:mod:`pipeline.tuning`). The section's context and figure are
made in :mod:`pipeline.report.sections` and :mod:`pipeline.report.plots`."""

from __future__ import annotations

import math

from ..tuning import RecordTuning, Tuning
from .tables import Cell, Table, fmt

RULE_TITLES = {
    "simc": "SIMC (Skogestad 2003)",
    "simc_improved": "improved SIMC (Grimholt & Skogestad 2018)",
    "lambda": "lambda / IMC (Rivera, Morari & Skogestad 1986)",
    "amigo": "AMIGO (Åström & Hägglund 2004)",
}
#: The tuning verdicts' badge colours reuse the fit verdicts' (same meaning of colour).
VERDICT_CLASS = {"robust": "ok", "fragile": "warning", "unstable_in_interval": "unreliable",
                 "unchecked": "info"}
FORM_TITLES = {"ideal": "ideal (ISA)", "parallel": "parallel", "series": "series"}


def _time(v: float, unit: str) -> str:
    if not math.isfinite(v):
        return "none"
    return f"{fmt(v / 60.0 if unit == 'min' else v)} {unit}"


def settings_table(rt: RecordTuning) -> Table:
    """The settings in every form, the chosen one first, times in the chosen unit."""
    t = rt.tuning
    unit = t.options.time_unit
    gu = rt.gain_unit
    tab = Table(["form", "gain", "integral", "derivative"])
    forms = [t.options.form] + [f for f in ("ideal", "parallel", "series")
                                if f != t.options.form]
    for form in forms:
        v = t.form(form, "s")
        if v is None:
            tab.rows.append([Cell(FORM_TITLES[form]), Cell("-"), Cell("-"),
                             Cell("no series form (Ti < 4 Td)")])
            continue
        if form == "parallel":
            per = 60.0 if unit == "min" else 1.0
            row = [Cell(f"Kp {fmt(v['Kp'])} {gu}", "num"),
                   Cell(f"Ki {fmt(v['Ki'] * per)} {gu}/{unit}", "num"),
                   Cell(f"Kd {fmt(v['Kd'] / per)} {gu}·{unit}", "num")]
        else:
            row = [Cell(f"Kc {fmt(v['Kc'])} {gu}", "num"), Cell(f"Ti {_time(v['Ti'], unit)}",
                                                             "num"),
                   Cell(f"Td {_time(v['Td'], unit)}" if v["Td"] > 0 else "Td 0", "num")]
        tab.rows.append([Cell(FORM_TITLES[form])] + row)
    if t.spread:
        tab.rows.append([Cell("ideal, over the 95 % intervals")] + _spread_cells(t, gu, unit))
    return Table(tab.columns, tab.rows, highlight=0)


def _spread_cells(t: Tuning, gu: str, unit: str) -> list[Cell]:
    """The ideal-form settings' range over the interval's parameter sets."""
    def rng(name: str, time: bool) -> Cell:
        if name not in t.spread:
            return Cell("-")
        lo, hi = t.spread[name]
        if time:
            return Cell(f"{name} {_time(lo, unit)} to {_time(hi, unit)}", "num")
        a, b = sorted((abs(lo), abs(hi)))  # magnitudes: the action carries the sign
        return Cell(f"{name} {fmt(a)} to {fmt(b)} {gu}", "num")
    return [rng("Kc", False), rng("Ti", True), rng("Td", True)]


def margins_table(t: Tuning) -> Table:
    """Nominal margins and, with an interval, the worst case over it."""
    m, w = t.margins, t.worst
    tab = Table(["", "Ms", "gain margin", "phase margin", "delay margin", "stable"])
    tab.rows.append([Cell("on the model"), Cell(fmt(m.ms, 3), "num"),
                     Cell(fmt(m.gain_margin, 3), "num"),
                     Cell(f"{fmt(m.phase_margin, 3)}°", "num"),
                     Cell(f"{fmt(m.delay_margin, 3)} s", "num"),
                     Cell("yes" if m.stable else "NO")])
    if w is not None:
        tab.rows.append([Cell(f"worst of {w.n_sets} sets in the 95 % intervals"),
                         Cell(fmt(w.ms, 3) if math.isfinite(w.ms) else "unstable", "num"),
                         Cell("-"), Cell("-"), Cell("-"),
                         Cell("yes" if w.stable else
                              f"{100 * (1 - w.stable_fraction):.3g} % unstable")])
    return tab


def response_table(t: Tuning, units: dict[str, str]) -> Table | None:
    """IAE, overshoot, settling time and the input's peak of the simulated loop."""
    if t.response is None:
        return None
    yu, uu = units.get("output", ""), units.get("input", "")
    tab = Table(["loop", "step", "IAE", "overshoot", "settling (2 %)", "input peak",
                 "input at a limit"])
    for name, r in (("on the model", t.response), ("worst case", t.worst_response)):
        if r is None:
            continue
        for step, m in (("setpoint", r.setpoint), ("load", r.load)):
            tab.rows.append([
                Cell(name), Cell(step), Cell(f"{fmt(m.iae, 3)} {yu}·s", "num"),
                Cell(f"{100 * m.overshoot:.3g} %" if step == "setpoint" else
                     f"peak {fmt(m.peak_deviation, 3)} {yu}", "num"),
                Cell(f"{fmt(m.settling_time, 3)} s" if math.isfinite(m.settling_time)
                     else "not settled", "num"),
                Cell(f"{fmt(m.u_peak, 3)} {uu}", "num"), Cell("yes" if m.saturated else "no")])
    return tab


def controller_lines(rt: RecordTuning) -> list[str]:
    """The tuning in a few plain lines for the terminal: settings in the chosen form and
    unit, the action, the margins and the verdict with its reason."""
    rule = RULE_TITLES.get(rt.rule, rt.rule)
    if not rt.ok:
        return [f"Controller: not tuned ({rule} on {rt.method}): {rt.reason}"]
    t = rt.tuning
    unit, gu = t.options.time_unit, rt.gain_unit
    gu_ = f" {gu}" if gu else ""
    form = t.options.form if t.form(None, "s") is not None else "ideal"
    v = t.form(form, "s")
    per = 60.0 if unit == "min" else 1.0
    if form == "parallel":
        settings = (f"Kp {fmt(v['Kp'])}{gu_}, Ki {fmt(v['Ki'] * per)}{gu_}/{unit}, "
                    f"Kd {fmt(v['Kd'] / per)}{gu_}·{unit}")
    else:
        settings = f"Kc {fmt(v['Kc'])}{gu_}, Ti {_time(v['Ti'], unit)}"
        if v["Td"] > 0:
            settings += f", Td {_time(v['Td'], unit)}"
    m, w = t.margins, t.worst
    worst = (f", worst case {fmt(w.ms, 3) if math.isfinite(w.ms) else 'unstable'}"
             if w is not None else "")
    lines = [f"Controller: {t.controller.kind} by {rule}: {t.verdict}",
             f"  {settings} ({FORM_TITLES[form]} form); {t.action} acting"
             + (f"; {fmt(t.percent_gain, 4)} %/%" if t.percent_gain is not None else ""),
             f"  Ms {fmt(m.ms, 3)}{worst}; gain margin {fmt(m.gain_margin, 3)}, phase margin "
             f"{fmt(m.phase_margin, 3)} deg, delay margin {fmt(m.delay_margin, 3)} s"]
    lines += [f"  {x}" for x in t.reasons]
    lines += [f"  note: {x}" for x in t.notes]
    return lines
