"""What the regression gate found: :class:`Finding` and :class:`Comparison` (pure values),
with their display forms for the report and the JUnit file (see :mod:`pipeline.gate.baseline`).

A drift of the plant moves every method's model, so one drifted gain is a finding per
method; a record is what regressed. :meth:`Comparison.by_record` groups the findings into
one :class:`RecordRegression` per record, headed by the finding on the record's
recommended model (the model to use), so the report, the terminal and JUnit say first
which records regressed and how, and fold the per-method detail below.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace


@dataclass(frozen=True)
class Finding:
    """One difference between the current results and the baseline.

    ``event`` and ``method`` are ``None`` for record-level findings. ``change`` is the
    relative change (a fraction; see the module docstring for the scale) for
    param_drift, mse_growth and tuning_drift, ``None`` otherwise. ``tolerance`` is the limit it was
    compared with.
    """

    record: str
    event: int | None
    method: str | None
    kind: str
    parameter: str | None = None
    baseline_value: float | str | None = None
    current_value: float | str | None = None
    change: float | None = None
    tolerance: float | None = None
    message: str = ""

    def __str__(self) -> str:
        return self.message

    @property
    def where(self) -> str:
        """``record``, or ``record event N method`` for a fit."""
        if self.method is None:
            return self.record
        return f"{self.record} event {self.event} {self.method}"

    def to_dict(self) -> dict:
        return asdict(self)

    def as_row(self) -> dict[str, str]:
        """Display strings for a report table: record, event, method, what, baseline,
        current, change."""
        what = {"mse_growth": "validation MSE", "status": "status",
                "tuning_verdict": "tuning verdict", "recommended": "recommended model",
                "verdict": "verdict",
                "missing": "missing", "new": "new"}.get(self.kind, self.parameter or "")
        return {
            "record": self.record,
            "event": "" if self.event is None else str(self.event),
            "method": self.method or "",
            "what": what,
            "baseline": display_text(self.baseline_value),
            "current": display_text(self.current_value),
            "change": "" if self.change is None else pct_text(self.change),
            "message": self.message,
        }


def severity(f: Finding) -> float:
    """How far past its tolerance a finding is (a status change or a missing item: inf)."""
    if f.change is None or not f.tolerance:
        return math.inf
    return abs(f.change) / f.tolerance


@dataclass(frozen=True)
class RecordRegression:
    """One regressed record: its ``headline`` finding and all of its ``findings``.

    ``model`` is the recommended model's label (``""`` when the record has none) and
    ``event`` its event. The headline is, in this order, a record-level finding (failed,
    missing), else the finding furthest past its tolerance on the recommended model
    (``on_recommended``), else the one furthest past its tolerance of any method.
    """

    record: str
    model: str
    event: int | None
    headline: Finding
    on_recommended: bool
    findings: tuple[Finding, ...]

    @property
    def on_model(self) -> tuple[Finding, ...]:
        """The findings of the recommended model (the headline's fit, for a record-level
        headline: none)."""
        return tuple(f for f in self.findings
                     if f.method == self.model and f.event == self.event and self.model)

    @property
    def other_methods(self) -> int:
        """How many other fits of the record regressed."""
        return len({(f.event, f.method) for f in self.findings if f.method is not None}
                   - {(self.event, self.model)})


@dataclass(frozen=True)
class Comparison:
    """The outcome of :func:`compare`: regressions, new items and missing items.

    ``recommended`` maps a record to its recommended fit ``(event, label)``: this run's,
    or the baseline's where this run has none.
    """

    regressions: tuple[Finding, ...] = ()
    new: tuple[Finding, ...] = ()
    missing: tuple[Finding, ...] = ()
    #: changes of the methods that are not the recommended model, beyond tolerance:
    #: information under the default scope "recommended" (regressions with "all")
    other: tuple[Finding, ...] = ()
    settings: dict = field(default_factory=dict)
    recommended: Mapping[str, tuple[int, str]] = field(default_factory=dict)

    def by_record(self) -> list[RecordRegression]:
        """One entry per regressed record, in the order the regressions came (the
        baseline's record order)."""
        groups: dict[str, list[Finding]] = {}
        for f in self.regressions:
            groups.setdefault(f.record, []).append(f)
        out = []
        for record, found in groups.items():
            event, model = self.recommended.get(record, (None, ""))
            whole = [f for f in found if f.method is None]
            on = [f for f in found if model and (f.event, f.method) == (event, model)]
            pool = whole or on or found
            head = max(pool, key=severity)  # max keeps the first of equals
            out.append(RecordRegression(record, model, event, head, bool(on) and not whole,
                                        tuple(found)))
        return out

    @property
    def regressed_records(self) -> list[str]:
        """The names of the records with a regression."""
        return list(dict.fromkeys(f.record for f in self.regressions))

    @property
    def ok(self) -> bool:
        """True when there is no regression (exit code 0 as far as the gate goes)."""
        return not self.regressions

    def for_fit(self, record: str, event: int | None, method: str | None) -> list[Finding]:
        """The regressions of one record (``event``/``method`` None: record-level)."""
        return [f for f in self.regressions
                if f.record == record and f.event == event and f.method == method]

    def summary(self) -> str:
        """One line: counts of regressions (and of the records they are in), new and
        missing items."""
        if self.ok:
            head = "no regression against the baseline"
        else:
            n_rec = len(self.regressed_records)
            head = f"{len(self.regressions)} regression(s) in {n_rec} record(s)"
        tail = f"; {len(self.other)} change(s) of other methods (information)" \
            if self.other else ""
        return f"{head}; {len(self.new)} new, {len(self.missing)} missing{tail}"

    def to_dict(self) -> dict:
        return {
            "ok": self.ok,
            "summary": self.summary(),
            "settings": dict(self.settings),
            "regressions": [f.to_dict() for f in self.regressions],
            "records": [{"record": r.record, "model": r.model, "event": r.event,
                         "headline": r.headline.to_dict(),
                         "on_recommended": r.on_recommended,
                         "findings": len(r.findings)} for r in self.by_record()],
            "new": [f.to_dict() for f in self.new],
            "other": [f.to_dict() for f in self.other],
            "missing": [f.to_dict() for f in self.missing],
        }


def recommended_fit(current, baseline) -> tuple[int, str] | None:
    """``(event, label)`` of a record's recommended model: the current record's (a
    :class:`~pipeline.schema.RecordDoc` or None), else the baseline's."""
    for rec in (current, baseline):
        if rec is not None and rec.recommended is not None:
            return (rec.recommended.event, rec.recommended.label)
    return None


def tag_recommended(f: Finding, recommended: Mapping[str, tuple[int, str] | None]) -> Finding:
    """A fit's finding with its message saying whether the fit is the record's recommended
    model (the terminal and JUnit show messages)."""
    if f.method is None or f.kind == "new":
        return f
    rec = recommended.get(f.record)
    tag = "recommended model" if rec == (f.event, f.method) else "not the recommended model"
    where = f"{f.record} event {f.event} {f.method}"
    return replace(f, message=f.message.replace(where, f"{where} ({tag})", 1))


def is_number(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def display_text(v) -> str:
    if v is None:
        return "-"
    return num_text(v) if is_number(v) else str(v)


def num_text(v: float) -> str:
    return f"{v:.4g}"


def pct_text(x: float, sign: bool = True) -> str:
    if not math.isfinite(x):
        return "inf" if x > 0 else "-inf"
    return f"{x * 100:+.1f} %" if sign else f"{x * 100:.1f} %"
