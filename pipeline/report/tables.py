"""The report's tables, built once from the results for Markdown, HTML and the terminal.

Number formats, labels and the parameter order come from the parameter table
(:data:`pipeline.models.PARAMETERS`); nothing here re-lists the vocabulary.
"""

from __future__ import annotations

import math

from ..models import PARAMETERS, STRUCTURES
from ..results import RecordResult


def fmt(v, digits: int = 4) -> str:
    """A number for a table cell ("-" for missing or non-finite)."""
    if v is None:
        return "-"
    if isinstance(v, float):
        if not math.isfinite(v):
            return "-"
        return f"{v:.{digits}g}"
    return str(v)


def params_text(params: dict | None, units: dict | None = None,
                structure: str | None = None) -> str:
    """``K=20.7, T=55.4, delay=3.64`` in the parameter table's order and formats (a zero
    dead time is left out); with the record's ``units``, each value carries its unit
    (``K=0.5 cm/V/s`` for an integrating ``structure``)."""
    if not params:
        return "-"
    order = list(PARAMETERS)
    names = sorted(params, key=lambda k: order.index(k) if k in order else len(order))
    return ", ".join(f"{k}={value_text(k, params[k], units, structure)}"
                     for k in names if not (k == "delay" and float(params[k]) == 0.0))


def value_text(name: str, value, units: dict | None = None, structure: str | None = None
               ) -> str:
    """One parameter value in its format, with its unit when ``units`` are given."""
    spec = PARAMETERS.get(name)
    if spec is None:
        return fmt(value)
    unit = ""
    if units is not None:
        integrating = structure in STRUCTURES and STRUCTURES[structure].integrating
        unit = spec.unit(units, integrating=integrating)
    return f"{spec.format(value)} {unit}" if unit else spec.format(value)


def dynamics_text(structure: str | None, params: dict, units: dict | None = None) -> str:
    """The dynamic parameters of a model (the structure table says which they are)."""
    if not structure or structure not in STRUCTURES:
        return "-"
    names = STRUCTURES[structure].dynamics
    return ", ".join(f"{k}={value_text(k, params[k], units)}" for k in names if k in params) \
        or "-"


def summary_rows(results: list[RecordResult], anchors: list[str]) -> list[dict]:
    """One row per record: status, events, the best method and its model."""
    rows = []
    for r, anchor in zip(results, anchors, strict=True):
        best = r.best
        p = best.model.params if best else {}
        units = r.record.units if r.record else None
        rows.append({
            "name": r.name, "anchor": anchor,
            "status": "ok" if r.ok else "failed", "reason": r.error or "",
            "events": len(r.events), "best": best.method if best else "-",
            "K": value_text("K", p["K"], units, best.model.structure) if "K" in p else "-",
            "dyn": dynamics_text(best.model.structure, p, units) if best else "-",
            "mse": fmt(best.metrics.get("mse_validation")) if best else "-",
        })
    return rows
