"""The method registry: each method is a pure function registered with its metadata.

``@register(id=..., event="step", structures=("first_order",), references=(...),
source="seed 001 ...")`` on ``def method(ev: EventData) -> MethodResult``. The id is the
public contract (DESIGN.md); ``structures`` are keys of
:data:`pipeline.models.STRUCTURES` (the models the method can return); ``references``
are keys of :data:`pipeline.methods.references.REFERENCES` (the original publications,
cited to users); ``source`` is the seed and equation the code follows (for developers).

:func:`identify` runs one method by id and turns
:class:`~pipeline.errors.NotApplicable` into a ``not_applicable`` fit and any other
exception into ``failed``: a method never raises through it (STYLE.md 3).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from ..errors import NotApplicable
from ..events import EventData
from ..fit import Fit
from ..models import STRUCTURES, ProcessModel
from .references import REFERENCES

#: Event kinds a method can need.
EVENT_KINDS = ("step", "impulse")


@dataclass(frozen=True)
class MethodResult:
    """What a method returns: the model and the points it read (t33, peaks, areas ...)."""

    model: ProcessModel
    diagnostics: dict = field(default_factory=dict)


@dataclass(frozen=True)
class MethodInfo:
    id: str
    event: str  # one of EVENT_KINDS
    structures: tuple[str, ...]
    references: tuple[str, ...]
    source: str
    func: Callable[[EventData], MethodResult]
    title: str = ""

    @property
    def citation(self) -> str:
        """The original publications, for users."""
        return "; ".join(REFERENCES[r] for r in self.references)


REGISTRY: dict[str, MethodInfo] = {}


def register(*, id: str, event: str, structures: tuple[str, ...], references: tuple[str, ...],
             source: str, title: str = ""):
    """Class-free registration decorator; checks the metadata against the tables."""

    def deco(func):
        if id in REGISTRY:
            raise ValueError(f"method id {id!r} registered twice")
        if event not in EVENT_KINDS:
            raise ValueError(f"method {id!r}: unknown event kind {event!r}")
        unknown = [s for s in structures if s not in STRUCTURES]
        unknown += [r for r in references if r not in REFERENCES]
        if unknown or not structures:
            raise ValueError(f"method {id!r}: unknown structures or references {unknown}")
        REGISTRY[id] = MethodInfo(id=id, event=event, structures=tuple(structures),
                                  references=tuple(references), source=source, func=func,
                                  title=title or id)
        return func

    return deco


def identify(ev: EventData, method: str) -> Fit:
    """Run method ``method`` on ``ev``; never raises for a registered id."""
    info = REGISTRY[method]
    if ev.kind != info.event:
        return Fit(method, ev.index, "not_applicable",
                   f"needs {_article(info.event)} event, this is {_article(ev.kind)} event")
    try:
        res = info.func(ev)
    except NotApplicable as exc:
        return Fit(method, ev.index, "not_applicable", exc.reason)
    except Exception as exc:  # a bug in one method must not lose the record's other fits
        return Fit(method, ev.index, "failed", f"internal error: {type(exc).__name__}: {exc}")
    bad = {k: v for k, v in res.model.params.items() if not _finite(v)}
    if bad:
        return Fit(method, ev.index, "failed", f"non-finite parameters {bad}",
                   diagnostics=res.diagnostics)
    if res.model.structure not in info.structures:
        return Fit(method, ev.index, "failed", f"internal error: returned a "
                   f"{res.model.structure} model, registered for {list(info.structures)}")
    outside = _outside_bounds(res.model)
    if outside:
        return Fit(method, ev.index, "not_applicable", f"the reading gives {outside}, outside "
                   "the structure's domain: the response does not have this shape",
                   diagnostics=res.diagnostics)
    return Fit(method, ev.index, "ok", None, res.model, {}, res.diagnostics)


def _outside_bounds(model: ProcessModel) -> str | None:
    """``"T = 0"`` for the first parameter outside its structure's bounds (a time constant
    must be positive where its lower bound is 0), else None."""
    for name, (lo, hi) in model.spec.bounds.items():
        v = float(model.params.get(name, 0.0 if name == "delay" else math.nan))
        strict = lo == 0.0 and name != "delay"
        if not (lo < v if strict else lo <= v) or not v <= hi:
            return f"{name} = {v:.4g}"
    return None


def _article(kind: str) -> str:
    return f"an {kind}" if kind[0] in "aeiou" else f"a {kind}"


def _finite(v) -> bool:
    return isinstance(v, int | float) and math.isfinite(v)
