"""The method registry: each method is a pure function registered with its metadata.

``@register(id=..., event="step", structures=("first_order",), references=(...),
source="seed 001 ...")`` on ``def method(ev: EventData) -> MethodResult``. The id is the
public contract (DESIGN.md); ``structures`` are keys of
:data:`pipeline.models.STRUCTURES` (the models the method can return); ``references``
are keys of :data:`pipeline.methods.references.REFERENCES` (the original publications,
cited to users); ``source`` is the seed and equation the code follows (for developers).

Two kinds of method: ``graphical`` (the transient-analysis methods, each a module of this
package) and ``refinement``: one least-squares method ``lsq_<structure>`` per entry of the
structure table, generated here (:func:`register_refinements`), so a new structure gets
its refinement with no further edit. A refinement run on an event alone starts from the
graphical methods' models of that event; :func:`pipeline.analyse.analyse` hands it the
ones it already has (:mod:`pipeline.refine_record`).

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
#: Method kinds: read points off one event, or fit the data by least squares.
METHOD_KINDS = ("graphical", "refinement")

#: Publications of the refinement (the graphical methods' are in references.py).
REFINEMENT_REFERENCES: dict[str, str] = {
    "ljung1999": "L. Ljung, System Identification: Theory for the User, 2nd ed., Prentice "
                 "Hall, 1999 (output-error models, prediction-error estimation, sec. 7.2, 9.3)",
    "golub1973": "G. H. Golub, V. Pereyra, \"The differentiation of pseudo-inverses and "
                 "nonlinear least squares problems whose variables separate\", SIAM J. Numer. "
                 "Anal. 10(2):413-432, 1973",
}


@dataclass(frozen=True)
class MethodResult:
    """What a method returns: the model and the points it read (t33, peaks, areas ...)."""

    model: ProcessModel
    diagnostics: dict = field(default_factory=dict)
    ci95: dict[str, tuple[float, float]] = field(default_factory=dict)


def _citations() -> dict[str, str]:
    return {**REFERENCES, **REFINEMENT_REFERENCES}


@dataclass(frozen=True)
class MethodInfo:
    id: str
    event: str  # one of EVENT_KINDS
    structures: tuple[str, ...]
    references: tuple[str, ...]
    source: str
    func: Callable[[EventData], MethodResult]
    title: str = ""
    kind: str = "graphical"  # one of METHOD_KINDS

    @property
    def citation(self) -> str:
        """The original publications, for users."""
        refs = _citations()
        return "; ".join(refs[r] for r in self.references)


REGISTRY: dict[str, MethodInfo] = {}


def register(*, id: str, event: str, structures: tuple[str, ...], references: tuple[str, ...],
             source: str, title: str = "", kind: str = "graphical"):
    """Class-free registration decorator; checks the metadata against the tables."""

    def deco(func):
        if id in REGISTRY:
            raise ValueError(f"method id {id!r} registered twice")
        if event not in EVENT_KINDS or kind not in METHOD_KINDS:
            raise ValueError(f"method {id!r}: unknown event or method kind {event!r}, {kind!r}")
        refs = _citations()
        unknown = [s for s in structures if s not in STRUCTURES]
        unknown += [r for r in references if r not in refs]
        if unknown or not structures:
            raise ValueError(f"method {id!r}: unknown structures or references {unknown}")
        REGISTRY[id] = MethodInfo(id=id, event=event, structures=tuple(structures),
                                  references=tuple(references), source=source, func=func,
                                  title=title or id, kind=kind)
        return func

    return deco


def refinement_id(structure: str) -> str:
    """The id of the least-squares refinement of ``structure``."""
    return f"lsq_{structure}"


def _refinement(structure: str) -> Callable[..., MethodResult]:
    def method(ev: EventData, **context) -> MethodResult:
        """``context``: ``models`` (starts), ``state``, ``options`` (see refine_event)."""
        from ..refine_record import refine_event, result_parts

        if ev.dy == 0 or not math.isfinite(ev.dy) or abs(ev.dy) <= 3 * ev.noise:
            raise NotApplicable("the output did not change measurably (|y_ss - y0| <= 3 "
                                "sigma)")
        model, diagnostics, ci95 = result_parts(refine_event(ev, structure, **context))
        return MethodResult(model, diagnostics, ci95)

    method.__doc__ = (f"Least-squares refinement of a {structure} model on one event "
                      "(pipeline.refine_record.refine_event).")
    return method


def register_refinements() -> None:
    """One ``lsq_<structure>`` per entry of :data:`pipeline.models.STRUCTURES` (those not
    registered yet)."""
    for name in STRUCTURES:
        if refinement_id(name) in REGISTRY:
            continue
        register(id=refinement_id(name), event="step", structures=(name,),
                 references=("ljung1999", "golub1973"), kind="refinement",
                 source="output-error least squares (pipeline.refine)",
                 title=f"least squares: {name.replace('_', ' ')}")(_refinement(name))


def identify(ev: EventData, method: str, **context) -> Fit:
    """Run method ``method`` on ``ev``; never raises for a registered id. ``context`` goes
    to a refinement: the graphical ``models`` to start from, the initial ``state``, the
    ``options`` (:func:`pipeline.refine_record.refine_event`)."""
    info = REGISTRY[method]
    if ev.kind != info.event:
        return Fit(method, ev.index, "not_applicable",
                   f"needs {_article(info.event)} event, this is {_article(ev.kind)} event")
    try:
        res = info.func(ev, **context) if context and info.kind == "refinement" else \
            info.func(ev)
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
    return Fit(method, ev.index, "ok", None, res.model, {}, res.diagnostics, dict(res.ci95))


def _article(kind: str) -> str:
    return f"an {kind}" if kind[0] in "aeiou" else f"a {kind}"


def _finite(v) -> bool:
    return isinstance(v, int | float) and math.isfinite(v)


register_refinements()
