"""The regression gate on a closed-loop log read with its setpoint (issue 32 item 3): the
plant fitted through the loop, and the controller that ran.

* **loop_plant_drift** (a regression) - a parameter of the plant fitted through the loop
  (results.json ``running_loop.plant``) moved beyond its tolerance (the gate's
  ``param_tol`` for a gain, the dynamics tolerance for the rest, as for any model:
  :meth:`pipeline.gate.baseline.Tolerances.for_param`) *and* beyond the two nights' 95 %
  half-widths combined (fresh noise moves a fit within its intervals). Compared only
  when both nights fitted the same structure through the loop; a plant fitted one night
  and not the next is information.
* **the running controller** (information, kind ``new``) - its kind changed, or a
  setting (``Kc``, ``Ti``, ``Td``, ideal form) moved beyond the dynamics tolerance: the
  loop was retuned, which changes the conditions the plant is seen in, not the plant.
"""

from __future__ import annotations

import math

from ..schema import RecordDoc
from .findings import Finding, num_text, pct_text

#: The plant through the loop as a gate finding names it (the ``method`` of its finding is
#: None: a record-level finding, which gates in every scope).
PLANT = "plant through the loop"


def loop_findings(name: str, cur: RecordDoc, base: RecordDoc, tol) -> list[Finding]:
    """The running loop's findings for one record ok in both runs (module docstring);
    ``tol`` is the gate's :class:`~pipeline.gate.baseline.Tolerances`."""
    b, c = base.running_loop, cur.running_loop
    if b is None and c is None:
        return []
    if b is None or c is None:
        what = "read with its setpoint now" if b is None else "no longer read with a setpoint"
        return [Finding(name, None, None, "new", "running loop",
                        message=f"{name} (the closed loop is {what})")]
    return [*_plant(name, b.plant, c.plant, tol), *_controller(name, b.controller,
                                                               c.controller, tol)]


def _plant(name: str, b, c, tol) -> list[Finding]:
    if b is None or c is None:
        if b is None and c is None:
            return []
        what = "fitted through the loop now" if b is None else "not fitted through the loop now"
        return [Finding(name, None, None, "new", PLANT, message=f"{name} (the plant is {what})")]
    if b.structure != c.structure:
        return [Finding(name, None, None, "new", PLANT, b.structure, c.structure,
                        message=f"{name} (the plant through the loop is a {c.structure} "
                                f"model now, was {b.structure}: not compared)")]
    out = []
    for p, bv in b.params.items():
        cv = c.params.get(p)
        if cv is None or not (math.isfinite(bv) and math.isfinite(cv)):
            continue
        scale = abs(bv) if bv else 1.0
        change = (cv - bv) / scale
        limit = tol.for_param(p)
        if abs(change) <= limit or _within(b.ci95.get(p), c.ci95.get(p), bv, cv):
            continue
        out.append(Finding(
            name, None, None, "loop_plant_drift", p, bv, cv, change, limit,
            message=f"{name}: the {PLANT}: {p} {num_text(bv)} -> {num_text(cv)} "
                    f"({pct_text(change)}, tolerance {pct_text(limit, sign=False)}), "
                    "beyond both nights' 95 % intervals"))
    return out


def _within(bci, cci, bv: float, cv: float) -> bool:
    """Whether the two values are within their 95 % half-widths combined."""
    halves = []
    for ci in (bci, cci):
        if not ci or ci[0] is None or ci[1] is None:
            return False
        halves.append((ci[1] - ci[0]) / 2)
    return abs(cv - bv) <= math.hypot(*halves)


def _controller(name: str, b, c, tol) -> list[Finding]:
    if b is None or c is None:
        return []
    if b.kind != c.kind:
        return [Finding(name, None, None, "new", "running controller", b.kind, c.kind,
                        message=f"{name} (the running controller is {c.kind} now, was "
                                f"{b.kind}: the loop was retuned)")]
    out = []
    for p in ("Kc", "Ti", "Td"):
        bv, cv = getattr(b, p), getattr(c, p)
        if bv is None or cv is None or not bv:
            continue
        change = (cv - bv) / abs(bv)
        if abs(change) > tol.dynamics:
            out.append(Finding(
                name, None, None, "new", f"running controller {p}", bv, cv, change,
                tol.dynamics, message=f"{name} (the running controller's {p} "
                                      f"{num_text(bv)} -> {num_text(cv)}, "
                                      f"{pct_text(change)}: the loop was retuned)"))
    return out
