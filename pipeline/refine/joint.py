"""One model over a span of the record, its state carried by the measured input: a step
that starts on a previous step's tail, several identification events with one model, and
leave-one-event-out cross-validation (in ten folds beyond ten events).

The model is simulated continuously from the baseline of the latest event that started at
rest (:func:`pipeline.refine.carry_source`; at rest there) to the end of the last
identification event, driven by the measured input, and fitted on the identification
events' samples only (:func:`span`): the events in between drive the state without entering
the criterion. With no earlier rest point the state is estimated at the first
identification event (:mod:`pipeline.simulation.regressors`).

* :func:`span_fit` with one event - a step on a tail: the tail is the same model's response
  to the earlier input, so the gain is identified (an estimated free response would look
  like the step response, see :mod:`pipeline.refine.event`);
* :func:`span_fit` with several - one gain, one offset, no per-event parameters: a plant
  whose gain changes with the operating point must show its misfit, not hide it;
* :func:`cross_validate` - the joint fit again without each event in turn (its samples
  left out, the state still carried through it) and its validation error on it
  (:mod:`pipeline.validate`): the held-out error; beyond :data:`MAX_FOLDS` events the
  events are left out in that many interleaved folds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..events import Event, EventData
from ..fit import Fit, Fold, InitialState
from ..models import ProcessModel
from ..record import Record
from ..validate import fit_start, heldout_residuals, validation_runs
from .event import carry_source, mismatch, structure_state, summary
from .fold_spread import widened_by_folds
from .left_out import left_out_fits
from .refinement import Refinement, RefineOptions, refine, refine_model
from .search import candidate_starts


@dataclass(frozen=True)
class Span:
    """Samples ``[start, stop)`` simulated, ``mask`` the fitted ones, the input level
    ``u_ref`` at the start, how the state starts ("rest" or "estimated"), and the event
    it is carried from (None: the first identification event's own start)."""

    start: int
    stop: int
    mask: np.ndarray
    u_ref: float
    state: InitialState
    carried_from: int | None


def span(events: Sequence[Event], ident: Sequence[int], states: Sequence[str],
         exclude: Sequence[int] = ()) -> Span:
    """The span of a fit over the events ``ident`` (``exclude``: left out of the
    criterion); ``states`` are the events' initial states (rest / estimated)."""
    first = ident[0]
    src = carry_source(states, first)
    origin = events[first if src is None else src]
    start = fit_start(origin.i_base, origin.i_start, origin.i_end)
    stop = events[ident[-1]].i_end
    mask = np.zeros(stop - start, bool)
    kept = [i for i in ident if i not in exclude]
    for i in kept:
        ev = events[i]
        # the first fitted event with its baseline (the state before it is seen), the
        # others from their step on (their baselines are the previous windows' tails)
        a = max(fit_start(ev.i_base, ev.i_start, ev.i_end), start) if i == kept[0] \
            else ev.i_start
        mask[a - start : ev.i_end - start] = True
    return Span(start, stop, mask, origin.u0, "estimated" if src is None else "rest",
                None if src is None or src == first else src)


def refine_span(record: Record, events: Sequence[Event], ident: Sequence[int], structure: str,
                *, models: Sequence[ProcessModel], states: Sequence[str],
                exclude: Sequence[int] = (), options: RefineOptions | None = None,
                starts: Sequence[dict[str, float]] | None = None
                ) -> tuple[Refinement, Span]:
    """One model of ``structure`` over :func:`span`, from ``starts`` (default: the
    candidate starts of ``models``, :func:`pipeline.refine.search.candidate_starts`), with at
    least :data:`ROWS_PER_EVENT` criterion rows per event (:func:`span_options`)."""
    s, state, args, kw = _span_problem(record, events, ident, structure, models, states,
                                       exclude, starts)
    ref = refine(*args, **kw, options=span_options(options, ident))
    return ref, s


def _refit_model(record: Record, events: Sequence[Event], ident: Sequence[int],
                 structure: str, *, models: Sequence[ProcessModel], states: Sequence[str],
                 exclude: Sequence[int], options: RefineOptions | None,
                 starts: Sequence[dict[str, float]] | None
                 ) -> tuple[ProcessModel, float]:
    """:func:`refine_span`'s model and input balance point alone
    (:func:`pipeline.refine.refinement.refine_model`: without the intervals a fold never reads)."""
    _, _, args, kw = _span_problem(record, events, ident, structure, models, states,
                                   exclude, starts)
    return refine_model(*args, **kw, options=span_options(options, ident))


def _span_problem(record: Record, events: Sequence[Event], ident: Sequence[int],
                  structure: str, models: Sequence[ProcessModel], states: Sequence[str],
                  exclude: Sequence[int], starts: Sequence[dict[str, float]] | None
                  ) -> tuple[Span, str, tuple, dict]:
    """The span, the model's initial state, and the arguments of a refinement over it."""
    s = span(events, ident, states, exclude)
    sl = slice(s.start, s.stop)
    horizon = float(record.t[s.stop - 1] - record.t[s.start])
    state = structure_state(structure, s.state, events[ident[0]])
    kw = {"u_ref": s.u_ref, "mask": s.mask, "initial_state": state,
          "starts": candidate_starts(structure, models, horizon) if starts is None
          else starts}
    return s, state, (record.t[sl], record.u[sl], record.y[sl], structure), kw


#: Criterion rows per identification event of a fit over several at least (block means of
#: the span's fit samples beyond, :class:`pipeline.refine.RefineOptions` ``max_rows``; the
#: search's decimated copy is as fine). The rows of a one-event fit, 600, spread over a
#: span of many events left about one row per event (600 events of 5,000 samples): the
#: transient was averaged away within each row, and the decimated search saw about one
#: sample per event, so a first-order plant (K 2, T 62 s) was fitted as K -1.6, T 1.3 s,
#: dead time 558 s. At 100 rows a window the rows are a few hundredths of it.
ROWS_PER_EVENT = 100


def span_options(options: RefineOptions | None, ident: Sequence[int]) -> RefineOptions:
    """The refinement options of a fit over the events ``ident``: at least
    :data:`ROWS_PER_EVENT` criterion rows per event."""
    opt = options or RefineOptions()
    return replace(opt, max_rows=max(opt.max_rows, ROWS_PER_EVENT * len(ident)))


#: Cross-validation folds at most: up to this many identification events each is left out
#: in turn (leave-one-event-out); beyond, event ``k`` joins fold ``k mod MAX_FOLDS``
#: (interleaved, so every fold spans the record's operating points), and the cost stays
#: ``MAX_FOLDS`` refits of the span, linear in the record, where leave-one-event-out was
#: one refit per event of the span (quadratic in the record). K-fold
#: cross-validation with K = 10 is the usual compromise between the bias of few folds
#: and the cost of many (Hastie, Tibshirani, Friedman, The Elements of Statistical
#: Learning, 2nd ed., 2009, sec. 7.10.1).
MAX_FOLDS = 10


def folds_of(ident: Sequence[int], max_folds: int = MAX_FOLDS) -> list[list[int]]:
    """The held-out groups of :func:`cross_validate`: one event each with up to
    ``max_folds`` events, else ``max_folds`` interleaved groups."""
    ident = list(ident)
    if len(ident) <= max_folds:
        return [[j] for j in ident]
    return [ident[k::max_folds] for k in range(max_folds)]


def held_out_events(ident: Sequence[int], event: int, at_most: int = MAX_FOLDS
                    ) -> list[int]:
    """The events a one-event model of ``event`` is scored on when every event
    identifies: the other identification events; beyond ``at_most`` of them, one set of
    ``at_most + 1`` events spread evenly over the record, the same for every model,
    less the model's own event (or its last, to keep ``at_most``), so any two models
    are compared on at least ``at_most - 1`` common events. Scoring each one-event model
    on all the others would cost events x samples, quadratic in the record."""
    ident = list(ident)
    others = [i for i in ident if i != event]
    if len(others) <= at_most:
        return others
    pick = np.round(np.linspace(0, len(ident) - 1, at_most + 1)).astype(int)
    spread = [ident[k] for k in np.unique(pick)]
    return [i for i in spread if i != event][:at_most]


def cross_validate(record: Record, events: Sequence[Event], ident: Sequence[int],
                   joint: ProcessModel, *, states: Sequence[str],
                   options: RefineOptions | None = None) -> tuple[float, tuple[Fold, ...]]:
    """Leave-one-event-out (leave-a-fold-out beyond :data:`MAX_FOLDS` events,
    :func:`folds_of`): for each fold, the joint fit without its events (started from the
    joint model, the state still carried through them) and its validation error on them.
    Beyond :data:`MAX_FOLDS` events the fold fits are Gauss-Newton steps from the joint
    model (:mod:`pipeline.refine.left_out`: a fold is a tenth of the events, its optimum near
    the joint one), with an exact refit where they do not converge; up to it every fold
    is refitted exactly, the record being short enough and a left-out event a large
    enough share of it for its optimum to lie in another basin (DaISy's lead-lag: the
    folds' costs 13-36 % above the exact refits' with the steps). A stepped fold keeps
    an integer order (n_lags' n) at the joint fit's: the order is chosen on all the
    events, which the exact refit of a fold re-chooses.
    Returns the pooled held-out MSE and one :class:`pipeline.fit.Fold` per fold."""
    held_out = folds_of(ident)
    stepped = len(ident) > MAX_FOLDS
    approx = (_stepped_folds(record, events, ident, joint, held_out, states, options)
              if stepped else [None] * len(held_out))
    if stepped:  # an exact refit polishes the joint model alone (a long record's
        # decimated search has a few samples per event: n_lags' folds lost the order
        # there; and every template scored on the whole span is a simulation of it)
        options = replace(options or RefineOptions(), coarse=False)
    # the pooled squared errors in one buffer, each fold's written as it is scored (not
    # the folds' errors, their concatenation and its square, each as long as the span)
    evs = list(events)
    sizes = [sum(b - a for a, b, _ in validation_runs(evs, held)) for held in held_out]
    squares, at = np.empty(sum(sizes)), 0
    folds = []
    for held, step, size in zip(held_out, approx, sizes, strict=True):
        if step is None:  # the steps did not converge: the exact refit
            model, u0 = _refit_model(record, events, ident, joint.structure,
                                     models=[joint], states=states, exclude=held,
                                     options=options,
                                     starts=[dict(joint.params)] if stepped else None)
        else:
            model, u0 = ProcessModel(joint.structure, step[0]), step[1]
        u0 = u0 if model.integrating else None
        e = heldout_residuals(model, record, evs, held, u0)[1]
        assert e.size == size, "a fold's errors are its validation runs' samples"
        np.square(e, out=squares[at: at + size])
        at += size
        folds.append(Fold(tuple(held), dict(model.params), u0,
                          float(np.mean(e**2)) if e.size else math.nan,
                          "exact" if step is None else "gauss-newton"))
        del e
    return (float(np.mean(squares)) if squares.size else math.nan), tuple(folds)


def _stepped_folds(record: Record, events: Sequence[Event], ident: Sequence[int],
                   joint: ProcessModel, held_out: Sequence[Sequence[int]],
                   states: Sequence[str], options: RefineOptions | None
                   ) -> list[tuple[dict[str, float], float] | None]:
    """The fold models by Gauss-Newton steps from the joint fit
    (:func:`pipeline.refine.left_out.left_out_fits`), None for a fold to refit exactly."""
    opt = span_options(options, ident)
    s = span(events, ident, states)
    sl = slice(s.start, s.stop)
    state = structure_state(joint.structure, s.state, events[ident[0]])
    masks = (span(events, ident, states, exclude=held).mask for held in held_out)  # one
    # span-long mask at a time (left_out_fits keeps each fold's rows only)
    return left_out_fits(record.t[sl], record.u[sl], record.y[sl], joint.structure,
                         u_ref=s.u_ref, masks=masks, initial_state=state,
                         params=joint.params, free_lags=opt.free_lags,
                         max_rows=opt.max_rows)


def fold_models(structure: str, folds: Sequence[Fold]
                ) -> list[tuple[list[int], ProcessModel, float | None]]:
    """The fold models of :func:`cross_validate` (a fit's ``refinement.folds``): held-out
    events, model, and an integrating model's balance point (None otherwise)."""
    return [(list(f.events), ProcessModel(structure, dict(f.params)), f.u0) for f in folds]


def span_fit(record: Record, events: Sequence[Event], ident: Sequence[int], method: str,
             structure: str, *, models: Sequence[ProcessModel], states: Sequence[str],
             cross_validation: bool = False, options: RefineOptions | None = None) -> Fit:
    """The fit of ``method`` over the events ``ident`` (:func:`span`): ``event`` the first,
    ``events`` all of them when there are several; the cross-validated error
    (:func:`cross_validate`) when ``cross_validation``. No output change is
    ``not_applicable``, a failure ``failed``; never an exception."""
    ident = list(ident)
    many = tuple(ident) if len(ident) > 1 else ()
    if all(abs(events[i].y_ss - events[i].y0) <= 3 * events[i].noise for i in ident):
        said = [(i, EventData.from_event(record, events[i]).unchanged_reason())
                for i in ident]
        i, why = next(((i, w) for i, w in said if "came back" in w), said[0])
        return Fit(method, ident[0], "not_applicable", f"event {i}: {why}" if many else why,
                   events=many)
    reasons = [(i, mismatch(structure, events[i])) for i in ident]
    i, reason = next(((i, r) for i, r in reasons if r), (None, None))
    if reason:
        return Fit(method, ident[0], "not_applicable", f"event {i}: {reason}" if many else
                   reason, events=many)
    try:
        ref, s = refine_span(record, events, ident, structure, models=models, states=states,
                             options=options)
        model, ci, refined = ref.model, dict(ref.ci95), summary(ref, s.carried_from)
        quantile = float(ref.diagnostics.get("quantile", math.nan))
        del ref  # its fit and residuals over the span (record-long on a long log)
        metrics = {}
        if cross_validation and many:
            fold_opt = replace(options or RefineOptions(), n_starts=1, bootstrap=0)
            metrics["mse_cross_validation"], folds = cross_validate(
                record, events, ident, model, states=states, options=fold_opt)
            refined = replace(refined, folds=folds)
        return widened_by_folds(Fit(method, ident[0], "ok", None, model, metrics, ci95=ci,
                                    events=many, refinement=refined), quantile)
    except Exception as exc:  # a bug in one fit must not lose the record's other fits
        return Fit(method, ident[0], "failed", f"internal error: {type(exc).__name__}: {exc}",
                   events=many)
