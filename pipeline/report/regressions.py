"""The report's Regressions section, the Summary's regression mark and the terminal lines
of the gate, from one :class:`~pipeline.gate.Comparison` (pure).

A drift of the plant moves every method's model: a 10 % gain drift is one finding per
method and record. The section opens with one row per regressed record, on its
recommended model (the model to use): the parameter furthest past its tolerance, the
baseline and current values, the change and the tolerance
(:meth:`~pipeline.gate.Comparison.by_record` picks it). Every finding, one per
method and parameter, follows in a second table (folded in ``<details>`` in HTML). The
Summary gets a "vs baseline" column beside the verdict that says ``regressed`` for those
records, and the terminal prints one line per regressed record.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from ..gate import Comparison, Finding, RecordRegression, display_text, pct_text
from .tables import Cell, Table

#: The terminal lists at most this many regressed records (the report lists them all).
TERMINAL_RECORDS = 10


@dataclass
class RegressionSection:
    """What the templates render: ``headline`` (one row per regressed record), ``detail``
    (one row per finding), the new items and the counts."""

    headline: Table
    detail: Table
    new: list[str] = field(default_factory=list)
    n_records: int = 0
    n_findings: int = 0
    #: where the findings are: "on the recommended models" (the default scope) or "over
    #: all methods" (``--gate all``)
    where: str = "on the recommended models"
    #: the other methods' changes beyond tolerance (information under the default scope)
    other: Table | None = None
    n_other: int = 0


def _tolerance(f: Finding) -> str:
    return "-" if f.tolerance is None else pct_text(f.tolerance, sign=False)


def _change(f: Finding) -> str:
    return "-" if f.change is None else pct_text(f.change)


def _more(r: RecordRegression) -> str:
    """The record's other findings, in words: the rest of the recommended model's, and
    how many other methods regressed."""
    rest = [f for f in r.on_model if f is not r.headline]
    parts = [", ".join(f"{f.as_row()['what']} {_change(f)}" for f in rest)] if rest else []
    if r.other_methods:
        parts.append(f"{r.other_methods} other method(s) regressed too")
    return "; ".join(parts) or "-"


def headline_row(r: RecordRegression, href: str | None = None) -> list[Cell]:
    f = r.headline
    what = f.as_row()["what"]
    note = ""
    if f.method is not None and not r.on_recommended:
        note = f"{f.method}, event {f.event}; not the recommended model"
    return [Cell(r.record, href=href), Cell(r.model or "-", "code",
                                             note="" if r.event is None else f"event {r.event}"),
            Cell(what, note=note), Cell(display_text(f.baseline_value), "num"),
            Cell(display_text(f.current_value), "num"), Cell(_change(f), "num"),
            Cell(_tolerance(f), "num"), Cell(_more(r))]


def detail_row(f: Finding, recommended: Mapping[str, tuple[int, str]]) -> list[Cell]:
    row = f.as_row()
    on = f.method is not None and recommended.get(f.record) == (f.event, f.method)
    return [Cell(f.record), Cell(row["event"] or "-", "num"),
            Cell(row["method"] or "-", "code", note="recommended" if on else ""),
            Cell(row["what"]), Cell(row["baseline"], "num"), Cell(row["current"], "num"),
            Cell(_change(f), "num"), Cell(_tolerance(f), "num")]


def regression_section(comparison: Comparison, anchors: Mapping[str, str] | None = None
                       ) -> RegressionSection:
    """The Regressions section of a comparison; ``anchors`` link record names to their
    report sections."""
    anchors = anchors or {}
    records = comparison.by_record()
    headline = Table(["record", "recommended model", "parameter", "baseline", "now",
                      "change", "tolerance", "also"])
    for r in records:
        href = f"#{anchors[r.record]}" if r.record in anchors else None
        headline.rows.append(headline_row(r, href))
    detail = Table(["record", "event", "method", "what", "baseline", "now", "change",
                    "tolerance"])
    detail.rows.extend(detail_row(f, comparison.recommended) for f in comparison.regressions)
    other = Table(detail.columns)
    other.rows.extend(detail_row(f, comparison.recommended) for f in comparison.other)
    return RegressionSection(headline, detail, [str(f) for f in comparison.new],
                             len(records), len(comparison.regressions),
                             where=_where(comparison), other=other,
                             n_other=len(comparison.other))


def _where(comparison: Comparison) -> str:
    return ("over all methods" if comparison.settings.get("scope") == "all"
            else "on the recommended models")


def mark_summary(summary: Table, comparison: Comparison, names: list[str],
                 failed: set[str] | frozenset[str] = frozenset()) -> Table:
    """The Summary table with a "vs baseline" column beside the verdict: ``regressed``,
    ``ok``, ``new`` for a record the baseline does not have, or ``failed`` for a record
    that failed in this run without regressing (it failed in the baseline too): never
    "ok" beside a failure. ``names`` are the records of the summary's rows, in order."""
    if "verdict" not in summary.columns or len(names) != len(summary.rows):
        return summary
    k = summary.columns.index("verdict") + 1
    regressed = set(comparison.regressed_records)
    new = {f.record for f in comparison.new if f.method is None}
    columns = summary.columns[:k] + ["vs baseline"] + summary.columns[k:]
    rows = []
    for name, row in zip(names, summary.rows, strict=True):
        mark = (Cell("regressed", "verdict") if name in regressed
                else Cell("failed") if name in failed
                else Cell("new") if name in new else Cell("ok"))
        rows.append(row[:k] + [mark] + row[k:])
    return Table(columns, rows, summary.highlight)


def gate_lines(comparison: Comparison, baseline: object, limit: int = TERMINAL_RECORDS
               ) -> list[str]:
    """The terminal's lines: one for the gate, then one per regressed record (the headline
    on its recommended model), at most ``limit`` of them."""
    records = comparison.by_record()
    other = (f"; {len(comparison.other)} change(s) of other methods, for information"
             if comparison.other else "")
    if not records:
        return [f"no regression against {baseline} ({len(comparison.new)} new, "
                f"{len(comparison.missing)} missing{other})"]
    lines = [f"{len(records)} record(s) regressed against {baseline} "
             f"({len(comparison.regressions)} finding(s) {_where(comparison)}{other}; the "
             "report lists them)"]
    for r in records[:limit]:
        f = r.headline
        what = f.as_row()["what"]
        on = f"{r.model} (recommended)" if r.on_recommended else (
            f"{f.method} (recommended: {r.model or 'none'})" if f.method else "record")
        value = f"{display_text(f.baseline_value)} -> {display_text(f.current_value)}"
        change = f" {_change(f)}, tolerance {_tolerance(f)}" if f.change is not None else ""
        more = _more(r)
        lines.append(f"  {r.record}: {on} {what} {value}{change}"
                     + ("" if more == "-" else f" [{more}]"))
    if len(records) > limit:
        lines.append(f"  ... and {len(records) - limit} more record(s)")
    return lines
