"""The method registry: each method is a pure function registered with its metadata.

``@register(id=..., event="step", structure="first_order", source="seed 001 ...")``
on ``def method(ev: EventData) -> MethodResult``. :func:`identify` runs one by id and
turns :class:`~pipeline.errors.NotApplicable` into a ``not_applicable`` fit and any other
exception into ``failed``: a method never raises through it (STYLE.md 3).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from ..errors import NotApplicable
from ..events import EventData
from ..fit import Fit
from ..models import ProcessModel


@dataclass(frozen=True)
class MethodResult:
    """What a method returns: the model and the points it read (t33, peaks, areas ...)."""

    model: ProcessModel
    diagnostics: dict = field(default_factory=dict)


@dataclass(frozen=True)
class MethodInfo:
    id: str
    event: str  # "step" | "impulse"
    structure: str  # model family, e.g. "K/(Ts+1)"
    order: str  # "first" | "second" | "nth": the report's overlay view
    source: str
    func: Callable[[EventData], MethodResult]
    title: str = ""


REGISTRY: dict[str, MethodInfo] = {}


def register(*, id: str, event: str, structure: str, order: str, source: str, title: str = ""):
    """Class-free registration decorator; the id is the public contract (DESIGN.md)."""

    def deco(func):
        if id in REGISTRY:
            raise ValueError(f"method id {id!r} registered twice")
        REGISTRY[id] = MethodInfo(id=id, event=event, structure=structure, order=order,
                                  source=source, func=func, title=title or id)
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
    return Fit(method, ev.index, "ok", None, res.model, {}, res.diagnostics)


def _article(kind: str) -> str:
    return f"an {kind}" if kind[0] in "aeiou" else f"a {kind}"


def _finite(v) -> bool:
    import math

    return isinstance(v, int | float) and math.isfinite(v)
