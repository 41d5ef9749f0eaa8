"""The least-squares refinements as methods: one ``lsq_<structure>`` per entry of the
structure table (:data:`pipeline.models.STRUCTURES`), generated here, so a new structure
gets its refinement with no further edit. Each runs :func:`pipeline.refine.event.
refine_event`, started from the graphical methods' readings of the same event. They take
steps and pulses alike (the measured input drives the model, whatever its shape).
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Sequence

from ..errors import NotApplicable
from ..events import Event, EventData
from ..fit import Fit
from ..models import STRUCTURES, ProcessModel
from ..record import Record
from ..refine import (
    RefineOptions,
    carry_source,
    mismatch,
    refine_event,
    span_fit,
    summary,
    unchanged,
)
from .base import input_change
from .registry import ANY_EVENT, REGISTRY, MethodResult, identify, register
from .second_order import light_ring, ring_behind_lag

#: The last event the graphical starts were computed for: ``identify(ev, "lsq_...")`` for
#: each structure on the same event object reuses them (an event is immutable).
_LAST_STARTS: list[tuple[weakref.ref, list[ProcessModel]]] = []


def graphical_models(ev: EventData) -> list[ProcessModel]:
    """The models of every graphical method that applies to the event (the starts of a
    refinement called on an event alone)."""
    if _LAST_STARTS and _LAST_STARTS[0][0]() is ev:
        return list(_LAST_STARTS[0][1])
    out = []
    for info in REGISTRY.values():
        if info.kind == "graphical" and info.event == ev.kind:
            fit = identify(ev, info.id)
            if fit.ok:
                out.append(fit.model)
    _LAST_STARTS[:] = [(weakref.ref(ev), out)]
    return list(out)


def ring_starts(ev: EventData, models: Sequence[ProcessModel], structure: str
                ) -> list[ProcessModel]:
    """Starts of a ``rings`` structure (``lag_second_order``) on an event whose step
    response rings (NotApplicable otherwise: a pair the response does not show is not
    determined; :func:`~pipeline.methods.second_order.light_ring`, or a ring the rise
    check refused behind a lag, :func:`~pipeline.methods.second_order.ring_behind_lag`):
    the ring's damping (its valley/peak decay, 0.1 when the valley is as deep as the
    peak; the decay of its two peaks behind a lag) and natural frequency (``wn = 2 pi/(P
    sqrt(1 - zeta^2))`` from the period ``P``; seed 001 "Determining the parameters")
    with the lag and dead time of every given model that has a lag (a lag model reads
    the slow part of the response), and with a lag of half the period behind no dead
    time."""
    reading = identify(ev, "second_order_overshoot") if ev.kind == "step" else None
    if light_ring(reading):
        z = reading.diagnostics.get("zeta_ratio")
        zeta = float(z) if z is not None else 0.1
        period = float(reading.diagnostics["period"])
    else:
        ring = ring_behind_lag(ev)
        if ring is None:
            raise NotApplicable("the response does not ring (no lightly damped oscillation "
                                "above the noise): a lag behind a lightly damped pair is "
                                "not determined by it")
        zeta, period = ring
    wn = 2.0 * math.pi / (period * math.sqrt(1.0 - zeta * zeta))
    K = ev.dy / ev.du
    lags = {(round(m.lags()[0], 12), round(m.delay, 12)) for m in models
            if m.lags() and m.lags()[0] > 0 and not m.spec.rings}
    lags.add((period / 2.0, 0.0))
    return [ProcessModel(structure, {"K": K, "T": T, "zeta": zeta, "wn": wn, "delay": d})
            for T, d in sorted(lags)]


def refinement_id(structure: str) -> str:
    """The id of the least-squares refinement of ``structure``."""
    return f"lsq_{structure}"


def _refinement(structure: str) -> Callable[..., MethodResult]:
    def method(ev: EventData, **context) -> MethodResult:
        """``context``: ``models`` (starts), ``state``, ``options`` (see refine_event)."""
        if ev.kind == "step":
            input_change(ev)  # a "step" whose input did not move: nothing to refine
        reason = mismatch(structure, ev) or unchanged(ev)
        if reason:
            raise NotApplicable(reason)
        if context.get("models") is None:
            context = {**context, "models": graphical_models(ev)}
        if STRUCTURES[structure].rings:
            context = {**context, "models": [
                *context["models"], *ring_starts(ev, context["models"], structure)]}
        ref = refine_event(ev, structure, **context)
        return MethodResult(ref.model, ci95=dict(ref.ci95), refinement=summary(ref))

    method.__doc__ = (f"Least-squares refinement of a {structure} model on one event "
                      "(pipeline.refine.refine_event).")
    return method


def register_refinements() -> None:
    """One ``lsq_<structure>`` per entry of :data:`pipeline.models.STRUCTURES` (those not
    registered yet)."""
    for name in STRUCTURES:
        if refinement_id(name) in REGISTRY:
            continue
        register(id=refinement_id(name), event=ANY_EVENT, structures=(name,),
                 references=("ljung1999", "golub1973"), kind="refinement",
                 source="output-error least squares (pipeline.refine)",
                 title=f"least squares: {name.replace('_', ' ')}")(_refinement(name))


register_refinements()


def event_fit(record: Record, events: Sequence[Event], i: int, method: str, *,
              models: Sequence[ProcessModel], states: Sequence[str],
              options: RefineOptions | None = None) -> Fit:
    """Refinement ``method`` on event ``i`` alone: with the state carried from an earlier
    event that started at rest (:func:`span_fit` over just this event) when the output was
    still moving at t0 and such an event exists, else on the event's own window with the
    state at rest or estimated (:func:`identify`)."""
    ev = events[i]
    if states[i] != "rest" and carry_source(list(states), i) is not None \
            and REGISTRY[method].accepts(ev.kind):
        return span_refinement(record, events, [i], method, models=models, states=states,
                               options=options)
    return identify(EventData.from_event(record, ev), method, models=models, state=states[i],
                    options=options)


def span_refinement(record: Record, events: Sequence[Event], ident: Sequence[int],
                    method: str, *, models: Sequence[ProcessModel], states: Sequence[str],
                    cross_validation: bool = False, options: RefineOptions | None = None
                    ) -> Fit:
    """:func:`pipeline.refine.span_fit` of refinement ``method`` over the events
    ``ident``; a ``rings`` structure (``lag_second_order``) only when one of them rings,
    started from its rings too (:func:`ring_starts`), as on one event alone."""
    structure = REGISTRY[method].structures[0]
    if STRUCTURES[structure].rings:
        starts, reason = [], None
        for i in ident:
            try:
                starts += ring_starts(EventData.from_event(record, events[i]), models,
                                      structure)
            except NotApplicable as exc:
                reason = reason or str(exc)
        if not starts:
            return Fit(method, ident[0], "not_applicable", reason,
                       events=tuple(ident) if len(ident) > 1 else ())
        models = [*models, *starts]
    return span_fit(record, events, ident, method, structure, models=models, states=states,
                    cross_validation=cross_validation, options=options)
