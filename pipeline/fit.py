"""``Fit`` and ``Flag``: the outcome of one method on one event (DESIGN.md "Core types")."""

from __future__ import annotations

from dataclasses import dataclass, field

from .models import ProcessModel

#: Fit statuses: a model, no model with the reason, or a method bug (the record goes on).
STATUSES = ("ok", "not_applicable", "failed")
#: Verdicts of a fit that has a model (DESIGN.md "Validation and grading").
VERDICTS = ("ok", "warning", "unreliable")


@dataclass(frozen=True)
class Flag:
    """One reason behind a verdict: a stable ``code``, a plain-words ``message`` and the
    numbers it was decided on."""

    code: str
    message: str
    values: dict[str, float | str | None] = field(default_factory=dict)
    severity: str = "warning"  # "warning" | "unreliable": the verdict it forces at least


@dataclass(frozen=True)
class Fit:
    """One method on one event: ``status`` and, when ok, the model with its metrics.

    ``ci95`` maps parameter names to 95 % intervals (refined models); ``verdict`` and
    ``flags`` are set by grading (None / empty until then); ``diagnostics`` are the points
    the method read (t63, peaks, areas ...), in absolute record time. ``events`` are all
    identification events of a model fitted over several of them (``event`` is the first);
    empty for a model of one event.
    """

    method: str
    event: int
    status: str
    reason: str | None = None
    model: ProcessModel | None = None
    metrics: dict[str, float] = field(default_factory=dict)
    diagnostics: dict = field(default_factory=dict)
    ci95: dict[str, tuple[float, float]] = field(default_factory=dict)
    verdict: str | None = None
    flags: tuple[Flag, ...] = ()
    events: tuple[int, ...] = ()

    @property
    def ok(self) -> bool:
        return self.status == "ok"
