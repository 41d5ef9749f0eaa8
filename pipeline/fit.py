"""``Fit``: the outcome of one method on one event (DESIGN.md "Core types")."""

from __future__ import annotations

from dataclasses import dataclass, field

from .models import ProcessModel


@dataclass(frozen=True)
class Fit:
    method: str
    event: int
    status: str  # "ok" | "not_applicable" | "failed"
    reason: str | None = None
    model: ProcessModel | None = None
    metrics: dict[str, float] = field(default_factory=dict)
    diagnostics: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> dict:
        return {
            "method": self.method, "event": self.event, "status": self.status,
            "reason": self.reason,
            "structure": self.model.structure if self.model else None,
            "params": dict(self.model.params) if self.model else None,
            "transfer_function": self.model.to_dict() if self.model else None,
            "metrics": dict(self.metrics), "diagnostics": _plain(self.diagnostics),
        }


def _plain(obj):
    """numpy scalars and arrays to JSON-friendly Python values."""
    import numpy as np

    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj
