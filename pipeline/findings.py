"""What the regression gate found: :class:`Finding` and :class:`Comparison` (pure values),
with their display forms for the report and the JUnit file (see :mod:`pipeline.baseline`)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field


@dataclass(frozen=True)
class Finding:
    """One difference between the current results and the baseline.

    ``event`` and ``method`` are ``None`` for record-level findings. ``change`` is the
    relative change (a fraction; see the module docstring for the scale) for
    param_drift and mse_growth, ``None`` otherwise. ``tolerance`` is the limit it was
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


@dataclass(frozen=True)
class Comparison:
    """The outcome of :func:`compare`: regressions, new items and missing items."""

    regressions: tuple[Finding, ...] = ()
    new: tuple[Finding, ...] = ()
    missing: tuple[Finding, ...] = ()
    settings: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when there is no regression (exit code 0 as far as the gate goes)."""
        return not self.regressions

    def for_fit(self, record: str, event: int | None, method: str | None) -> list[Finding]:
        """The regressions of one record (``event``/``method`` None: record-level)."""
        return [f for f in self.regressions
                if f.record == record and f.event == event and f.method == method]

    def summary(self) -> str:
        """One line: counts of regressions, new and missing items."""
        if self.ok:
            head = "no regression against the baseline"
        else:
            n_rec = len({f.record for f in self.regressions})
            head = f"{len(self.regressions)} regression(s) in {n_rec} record(s)"
        return f"{head}; {len(self.new)} new, {len(self.missing)} missing"

    def to_dict(self) -> dict:
        return {
            "ok": self.ok,
            "summary": self.summary(),
            "settings": dict(self.settings),
            "regressions": [f.to_dict() for f in self.regressions],
            "new": [f.to_dict() for f in self.new],
            "missing": [f.to_dict() for f in self.missing],
        }


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
