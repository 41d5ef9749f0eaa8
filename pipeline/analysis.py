"""One record, analysed: segment, identify on the chosen events, refine, validate on the
others, grade every fit, recommend a model.

:func:`analyse` is pure (a :class:`~pipeline.record.Record` and :class:`AnalysisOptions`
in, a :class:`~pipeline.results.RecordResult` out) and is the only analysis path: the
``identify`` and ``run`` commands, the batch workers and the Python API all call it, so
they give the same fits for the same record and options.

Per identification event the graphical methods run first; the refinements
(``lsq_<structure>``, :mod:`pipeline.refine.event`) start from their models. With several
identification events each refinement also runs once over all of them (one model, the
state carried through the record), and with ``events: all`` leave-one-event-out
cross-validation gives its held-out error (``mse_cross_validation``; a one-event model's
is its error on the other events; beyond ten events, ten folds and ten spread events:
:func:`pipeline.refine.joint.folds_of`, :func:`pipeline.refine.held_out_events`). Every ok fit
gets an information criterion on its own event (``aic``). With three steps or more every
step is also identified on its own (:mod:`pipeline.grading.consistency`); grading flags what
disagrees, and the record gets its recommended model (:func:`pipeline.grading.recommend`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from .events import EventData
from .fit import Fit
from .grading import (
    grade,
    information_criteria,
    no_usable_model,
    per_step,
    ranked,
    recommend,
)
from .methods import REGISTRY, event_fit, identify, select_methods, span_refinement
from .metrics import mse
from .outliers import without_outliers
from .parallel import Workers, spread, worth_spreading
from .record import Record
from .refine import RefineOptions, event_states, held_out_events, noise_bar, widened
from .results import RecordResult
from .segmentation import SegmentOptions, segment
from .tuning import (
    THROUGH_LOOP,
    RecordTuning,
    TuningOptions,
    model_trust,
    read_loop,
    through_loop_trust,
    tune,
    with_plant,
)
from .validate import heldout_residuals, identification_residuals, score

#: An event window with fewer samples after t0 gives no model (never a silent bad one).
MIN_WINDOW_SAMPLES = 10


@dataclass(frozen=True)
class AnalysisOptions:
    """What to do with a record (the config's segmentation, identification and methods).

    ``events``: the identification events (indices, or "all"); the others validate.
    ``methods``: "all" (every method for each event's kind) or a list of ids.
    ``refine``: options of the least-squares refinements (starts, bootstrap).
    ``consistency``: identify every step on its own and compare them
    (:mod:`pipeline.grading.consistency`); None: when there are three steps or more.
    ``tuning``: the controller tuned from the recommended model (:func:`tuned`).
    """

    segmentation: SegmentOptions = field(default_factory=SegmentOptions)
    events: tuple[int, ...] | str = (0,)
    methods: tuple[str, ...] | str = "all"
    refine: RefineOptions = field(default_factory=RefineOptions)
    consistency: bool | None = None  # each step on its own (None: with 3 steps or more)
    #: how to tune a controller from the recommended model (None: no tuning)
    tuning: TuningOptions | None = field(default_factory=TuningOptions)


def analyse(record: Record, options: AnalysisOptions | None = None, *,
            name: str | None = None, workers: Workers | None = None) -> RecordResult:
    """Segment, identify on the chosen events, validate on the others (pure).

    A record that cannot be analysed (no event, a missing identification event) comes
    back with ``error`` set; a method that does not apply gives a ``not_applicable`` fit.
    ``workers``: processes for the independent work of a long record (each event's
    methods, each refinement over all events, the held-out errors, the per-step
    consistency, the grading: :mod:`pipeline.parallel`); the result is the same without
    them.
    """
    opt = options or AnalysisOptions()
    # a closed loop's controller is read off the measurement it saw, glitches and all
    loop = None if record.r is None else read_loop(record.t, record.r, record.y, record.u,
                                                   setpoint=record.setpoint_name or "r")
    record = without_outliers(record)  # a glitch is named (outlier_samples), not fitted
    base = RecordResult(name=name or record.name, source=record.source, record=record,
                        loop=loop)
    events = segment(record, opt.segmentation)
    if not events:
        return replace(base, error=no_event_message(record))
    base = replace(base, events=events)
    ident = (list(range(len(events))) if opt.events == "all" else sorted(set(opt.events)))
    if not ident:
        return replace(base, error=f"{record.source}: no identification event was chosen")
    missing = [i for i in ident if not 0 <= i < len(events)]
    if missing:
        return replace(base, error=(
            f"{record.source}: identification event {missing[0]} does not exist; the record "
            f"has {len(events)} event(s) (0..{len(events) - 1})"))
    validation = [e.index for e in events if e.index not in ident]
    roles = {e.index: ("identification" if e.index in ident else "validation") for e in events}
    states = event_states(record, events)
    pool = worth_spreading(workers, sum(events[i].i_end - events[i].i_start for i in ident),
                           len(ident), record_samples=record.n_samples)
    shared = (record, events, ident, validation, states, opt)
    fits = [f for fs in spread(pool, _event_fits, shared, ident) for f in fs]
    if len(ident) > 1:
        models = tuple(f.model for f in fits if f.ok and f.event == ident[0])
        fits.extend(spread(pool, _joint_fit, (*shared, models), _joint_methods(events, ident,
                                                                               opt)))
    if opt.events == "all" and len(ident) > 1:
        fits = spread(pool, _held_out, shared, fits)
    fits = _with_information_criteria(record, events, fits)
    result = replace(base, roles=roles, fits=fits)
    # the per-step consistency is judged at the dynamics of a first choice; the
    # recommendation is then made again from the verdicts and flags grading gave
    cons = per_step(result, recommend(result), states, setting=opt.consistency,
                    options=opt.refine, workers=workers)
    graded = grade(replace(result, consistency=cons), workers=workers)
    recommendation = recommend(graded)
    chosen = graded.fit(recommendation.method, recommendation.event,
                        recommendation.events) if recommendation else None
    if chosen is not None and chosen.verdict == "unreliable":  # never the answer
        return _through_loop(replace(graded, flags=graded.flags + (
            no_usable_model(graded, chosen),)), record, None)
    final = _through_loop(replace(graded, recommendation=recommendation), record, chosen)
    if opt.tuning is None:
        return final
    return replace(final, tuning=tuned(final, opt.tuning))


def _through_loop(result: RecordResult, record: Record, chosen: Fit | None) -> RecordResult:
    """A closed-loop log's reading with the plant fitted through the loop (the indirect
    approach, :func:`pipeline.tuning.with_plant`), from the recommended direct fit; where
    its structure cannot be closed (no exact filter of order 1 or 2, a direct
    feedthrough), from the event's other refinements of other structures in the order
    of the recommendation's criterion (the first reason is kept if none can)."""
    if result.loop is None:
        return result
    if chosen is None or chosen.model is None:
        return replace(result, loop=replace(result.loop, plant_reason=(
            "no usable direct fit of the plant to start the loop's fit from")))
    others = [f for f in ranked(result, chosen.event) if f.is_refined and f.model is not None
              and f.model.structure != chosen.model.structure]
    first = None
    for f in [chosen, *others]:
        loop = with_plant(result.loop, record.t, record.r, record.y, f.model.structure,
                          f.model.params)
        if loop.plant is not None:
            return replace(result, loop=loop)
        first = first or loop
    return replace(result, loop=first)


def tuned(result: RecordResult, options: TuningOptions) -> RecordTuning | None:
    """The controller tuned from ``result``'s recommended model (pure; None without one).

    The loop is simulated at the identification event's operating point (its ``u0``): a
    setpoint step of half the output change the test's input step gave (``K du/2``; for an
    integrating model half the output change over the event), which settles with the
    input mid-range, then a load step of a quarter of the test's input step at the plant
    input, with the actuator limited to the input range the log saw (or
    ``options.u_limits``). A model whose verdict is unreliable or that is
    flagged closed-loop gives no "robust" tuning. A closed-loop log whose plant was
    fitted through the loop (:func:`pipeline.tuning.with_plant`) is tuned from that
    plant and its intervals instead (:data:`pipeline.tuning.THROUGH_LOOP`): the direct fit
    is the one flagged closed-loop."""
    fit, rec = result.recommended, result.record
    if fit is None or fit.model is None or rec is None:
        return None
    plant = result.loop.plant if result.loop is not None else None
    model = fit.model if plant is None else plant.model
    ev = result.events[fit.event]
    du = ev.u_ss - ev.u0 if ev.kind == "step" else float(np.ptp(rec.u)) / 2.0
    if model.integrating:
        window = rec.y[ev.i_start:ev.i_end]
        r_step = float(window[-1] - window[0]) / 2.0 if window.size > 1 else model.K
    else:
        r_step = model.K * du / 2.0
    lo, hi = options.u_limits or (float(np.min(rec.u)), float(np.max(rec.u)))
    limits = (min(lo - ev.u0, 0.0), max(hi - ev.u0, 0.0))
    if plant is None:
        trusted, why = model_trust(fit.verdict, (f.code for f in (*fit.flags, *result.flags)),
                                   (f.code for f in fit.flags if f.severity == "warning"))
        ci95 = fit.ci95
        cov = fit.refinement.covariance if fit.refinement is not None else None
    else:  # its intervals are the loop fit's (no covariance kept: the box is checked)
        trusted, why = through_loop_trust(f.code for f in result.flags)
        ci95, cov = plant.ci95, None
    base = RecordTuning(method=fit.method if plant is None else THROUGH_LOOP,
                        event=fit.event, events=tuple(fit.events) if plant is None else (),
                        rule=options.rule, units=dict(rec.units), r_step=r_step,
                        d_step=du / 4.0, u_limits=limits)
    try:
        t = tune(model, options, ci95=ci95, covariance=cov, trusted=trusted, why_not=why,
                 r_step=r_step or 1.0, d_step=du / 4.0 or None, u_limits=limits)
    except ValueError as exc:
        return replace(base, reason=str(exc))
    return replace(base, tuning=t)


def no_event_message(record: Record) -> str:
    """Why a record has no event, and what to do: an input constant over the whole record
    says its level and that a step just before the first row is declared as the level
    before it (``initial_input``)."""
    msg = f"{record.source}: no step or impulse event found in the input {record.input_name!r}"
    u = record.u
    if u.size and float(np.max(u) - np.min(u)) <= 1e-9 * max(1.0, float(np.max(np.abs(u)))):
        msg += (f" (it is constant at {float(u[0]):.6g}); if it stepped to that level just "
                "before the first row, declare the level before it as initial_input "
                "(data.initial_input in a config, --initial-input on the command line)")
    return msg


def _event_fits(shared: tuple, i: int) -> list[Fit]:
    """The graphical methods, then the refinements, on event ``i`` (its state at rest,
    carried from an earlier event that was, or estimated: :mod:`pipeline.refine.joint`).
    ``shared``: the record, its events, the identification and validation events, their
    states and the options (one task of :func:`pipeline.parallel.spread`)."""
    record, events, ident, validation, states, opt = shared
    ev = events[i]
    # the events a refinement's intervals learn the noise from: its validation events, or
    # with every event identifying the ones its cross-validation error is taken on
    crossed = not validation and opt.events == "all" and len(ident) > 1
    heldout = held_out_events(ident, i) if crossed else validation
    refine_opt = replace(opt.refine, sensitivity=True) if heldout else opt.refine
    data = EventData.from_event(record, ev)
    selected = select_methods(opt.methods, ev.kind)
    short = ev.i_end - ev.i_start < MIN_WINDOW_SAMPLES
    out: list[Fit] = []
    graphical = [m for m in selected if m not in REGISTRY or REGISTRY[m].kind != "refinement"]
    for mid in graphical + [m for m in selected if m not in graphical]:
        if short:
            out.append(Fit(mid, i, "not_applicable", f"window too short: "
                           f"{ev.i_end - ev.i_start} samples after t0, at least "
                           f"{MIN_WINDOW_SAMPLES} are needed"))
            continue
        t0 = time.perf_counter()
        if mid in REGISTRY and REGISTRY[mid].kind == "refinement":
            fit = event_fit(record, events, i, mid, models=[f.model for f in out if f.ok],
                            states=states, options=refine_opt)
        else:
            fit = identify(data, mid)
        if fit.ok and fit.is_refined and heldout:
            residuals = heldout_residuals(fit.model, record, events, heldout,
                                          fit.balance_point)
            fit = widened(fit, *residuals, noise_bar(fit, [events[k] for k in heldout]))
            metrics = score(fit.model, record, events, ev, validation, fit.balance_point,
                            heldout=None if crossed else residuals)
            if crossed:  # what _held_out would give it
                metrics["mse_cross_validation"] = mse(residuals[1], 0 * residuals[1])
            fit = replace(fit, metrics=metrics)
        elif fit.ok:
            fit = replace(fit, metrics=score(fit.model, record, events, ev, validation,
                                             fit.balance_point))
        out.append(replace(fit, seconds=time.perf_counter() - t0))
    return out


def _joint_methods(events, ident: list[int], opt: AnalysisOptions) -> list[str]:
    """The selected refinements for the identification events' kinds, each once."""
    kinds = {events[i].kind for i in ident}
    return list(dict.fromkeys(m for k in sorted(kinds) for m in select_methods(opt.methods, k)
                              if m in REGISTRY and REGISTRY[m].kind == "refinement"))


def _joint_fit(shared: tuple, mid: str) -> Fit:
    """Refinement ``mid`` once over all identification events, started from the first
    event's models (``shared``: :func:`_event_fits`' and those models)."""
    record, events, ident, validation, states, opt, models = shared
    t0 = time.perf_counter()
    fit = span_refinement(record, events, ident, mid, models=models, states=states,
                          cross_validation=opt.events == "all", options=opt.refine)
    if fit.ok:
        metrics = score(fit.model, record, events, events[ident[0]], validation,
                        fit.balance_point)
        fit = replace(fit, metrics={**metrics, **fit.metrics})
    return replace(fit, seconds=time.perf_counter() - t0)


def _held_out(shared: tuple, fit: Fit) -> Fit:
    """With every event identifying: a one-event model's error on the other events (at
    most :data:`pipeline.refine.joint.MAX_FOLDS` of them,
    :func:`pipeline.refine.held_out_events`)."""
    record, events, ident = shared[:3]
    if not fit.ok or fit.events or "mse_cross_validation" in fit.metrics:
        return fit
    _, e = heldout_residuals(fit.model, record, events, held_out_events(ident, fit.event),
                             fit.balance_point)
    return replace(fit, metrics={**fit.metrics, "mse_cross_validation": mse(e, 0 * e)})


def _with_information_criteria(record: Record, events, fits: list[Fit]) -> list[Fit]:
    """``aic`` of every ok one-event fit on its event's baseline and window."""
    out = list(fits)
    for ev in events:
        idx = [k for k, f in enumerate(fits) if f.ok and f.event == ev.index and not f.events]
        if not idx:
            continue
        errors = [identification_residuals(fits[k], record, ev) for k in idx]
        aics = information_criteria(errors, [fits[k].n_params for k in idx])
        for k, a in zip(idx, aics, strict=True):
            out[k] = replace(fits[k], metrics={**fits[k].metrics, "aic": a})
    return out
