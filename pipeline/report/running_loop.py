"""The report's "Running controller" section and its terminal lines: a closed-loop log
read with its setpoint (:func:`pipeline.tuning.read_loop`): the settings of the
controller that ran, with their standard errors, and the setpoint overshoot method's PI
settings from each setpoint step of a loop under P control, and the plant fitted through
the loop with that controller beside the direct fit."""

from __future__ import annotations

import math

from ..tuning import LoopReading, controller_gain_unit
from .tables import Cell, Table, _unit, fmt


def _gain_unit(units: dict[str, str]) -> str:
    unit = controller_gain_unit(units)
    return f" {unit}" if unit else ""


def _setting(v: float, se: float | None, unit: str = "") -> str:
    if not math.isfinite(v):
        return "none"
    s = f"{fmt(v)}{unit}"
    return s + (f" (s.e. {fmt(se, 2)})" if se is not None and math.isfinite(se) else "")


def running_summary(reading: LoopReading, units: dict[str, str]) -> str:
    """The running controller in one line (its kind and ideal-form settings), or why it
    could not be read."""
    run = reading.running
    if run is None:
        return f"not read: {reading.reason}"
    c, se, gu = run.controller, run.std, _gain_unit(units)
    parts = [f"Kc {_setting(c.Kc, se.get('Kc'), gu)}"]
    if math.isfinite(c.Ti):
        parts.append(f"Ti {_setting(c.Ti, se.get('Ti'), ' s')}")
    if c.Td > 0:
        parts.append(f"Td {_setting(c.Td, se.get('Td'), ' s')}")
    text = f"{c.kind}, " + ", ".join(parts) + " (ideal form)"
    if not run.converged:
        text += "; the derivative filter did not converge"
    if run.residual_share > 0.1:
        text += (f"; {100 * run.residual_share:.2g} % of the controller output is not "
                 "explained by these settings (limits, quantisation or another form)")
    return text


def steps_table(reading: LoopReading, units: dict[str, str]) -> Table:
    """Each setpoint step and the setpoint overshoot method's PI settings from it."""
    gu = _gain_unit(units)
    tab = Table(["setpoint step", "overshoot", "peak time", "PI by the overshoot method"])
    for st in reading.steps:
        if st.controller is None or st.test is None:
            result = st.reason or "-"
            over = peak = "-"
        else:
            c = st.controller
            result = f"Kc {fmt(c.Kc)}{gu}, Ti {fmt(c.Ti)} s"
            over, peak = f"{100 * st.test.overshoot:.3g} %", f"{fmt(st.test.tp)} s"
        tab.rows.append([Cell(f"{fmt(st.change, 3)} at {fmt(st.time)} s"), Cell(over, "num"),
                         Cell(peak, "num"), Cell(result)])
    return tab


def plant_summary(reading: LoopReading, direct=None, units: dict[str, str] | None = None
                  ) -> str:
    """The plant fitted through the loop in one line, its parameters in the record's
    ``units`` with their 95 % intervals, and the direct fit ``direct`` (the recommended
    fit from the controller output) against them: the direct approach's bias where a
    parameter falls outside them."""
    pl = reading.plant
    if pl is None:
        return f"not fitted: {reading.plant_reason}" if reading.plant_reason else ""
    parts = []
    for n, v in pl.model.params.items():
        unit = _unit(n, units, pl.model.structure)
        unit = f" {unit}" if unit else ""
        if n in pl.ci95:
            lo, hi = pl.ci95[n]
            parts.append(f"{n} {fmt(v)}{unit} [{fmt(lo, 3)}, {fmt(hi, 3)}]")
        else:
            parts.append(f"{n} {fmt(v)}{unit} (held)")
    text = f"{pl.model.structure.replace('_', ' ')}: " + ", ".join(parts) + " (95 %)"
    if direct is not None and direct.model is not None and \
            direct.model.structure == pl.model.structure:
        out = [n for n, v in direct.model.params.items() if n in pl.ci95 and
               not pl.ci95[n][0] <= v <= pl.ci95[n][1]]
        text += ("; the direct fit (" + direct.method + ") is inside these intervals" if not
                 out else f"; the direct fit ({direct.method}) has {', '.join(out)} outside "
                 "them: its estimate is biased by the loop")
    return text


def running_loop_lines(reading: LoopReading, units: dict[str, str], direct=None
                       ) -> list[str]:
    """The reading in a few plain lines for the terminal."""
    lines = [f"Running controller (setpoint '{reading.setpoint}'): "
             f"{running_summary(reading, units)}"]
    plant = plant_summary(reading, direct, units)
    if plant:
        lines.append(f"  plant through the loop (indirect, the setpoint to the output): {plant}")
    gu = _gain_unit(units)
    for st in reading.steps:
        head = f"  setpoint step {fmt(st.change, 3)} at {fmt(st.time)} s: "
        if st.controller is None or st.test is None:
            lines.append(head + (st.reason or "-"))
        else:
            lines.append(head + f"overshoot {100 * st.test.overshoot:.3g} %, PI by the "
                         f"setpoint overshoot method Kc {fmt(st.controller.Kc)}{gu}, "
                         f"Ti {fmt(st.controller.Ti)} s")
    return lines


def running_loop_context(reading: LoopReading | None, units: dict[str, str], direct=None
                         ) -> dict | None:
    """The template context of the section (None: an open-loop log)."""
    if reading is None:
        return None
    return {"setpoint": reading.setpoint, "summary": running_summary(reading, units),
            "plant": plant_summary(reading, direct, units),
            "steps": steps_table(reading, units) if reading.steps else None}
