"""Grading: a verdict for every fit, with the reasons behind it (DESIGN.md "Validation and
grading"). A model that is wrong must never look right.

Each :class:`~pipeline.fit.Flag` has a stable code (:data:`FLAGS`), a message in plain
words with the numbers it was decided on, and a severity: ``unreliable`` (the model is
unusable), ``warning`` (it is limited: an extrapolated gain, a misfit beyond the noise, a
parameter the data do not determine and that matters) or ``info`` (worth knowing, no
limit on the model: a residual colour the noise explains, a parameter undetermined where
it does not change the response). The verdict is the worst severity among a fit's flags,
``info`` not counted: ``ok``, ``warning`` (use with care: the message says what to check)
or ``unreliable`` (do not use the model). Record-level findings (a closed
loop, per-event gains that disagree) are attached to every fit of the record, since they
undermine all of them.

The checks are pure functions of the record, its events and the fit; every threshold is a
named constant with its reasoning.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..events import MOVED_SIGMAS, Event, EventData
from ..fit import VERDICTS, Fit, Flag
from ..models import PARAMETERS
from ..parallel import Workers, spread, worth_spreading
from ..record import Record, in_time_unit
from ..refine import baseline_drift
from ..results import RecordResult
from .closed_loop import closed_loop_flag
from .consistency import gain_flags
from .determinacy import response_band, response_change
from .heldout import MISFIT_RATIO, fit_floor, output_unit, own_rms, validation_misfit
from .oscillation import oscillation_unmodelled

#: Every flag code, with what it means (the report's legend and the docs read this).
FLAGS: dict[str, str] = {
    "unsettled": "the window ends before the output settles: the gain is a lower bound or "
                 "extrapolated",
    "baseline_not_steady": "the output was still moving before the step: y0 and the gain "
                           "are biased",
    "overshoot_within_noise": "the oscillation the model claims is no larger than the noise",
    "dynamics_below_sample_time": "a time constant is shorter than the sample time: the data "
                                  "only say it is fast",
    "delay_clipped": "the method computed a negative dead time and set it to 0",
    "poor_fit": "the model explains less than half of the validation data's variation",
    "negative_fit": "the model is worse than a constant on the validation data",
    "residuals_not_white": "the model misses the data by much more than the noise: the "
                           "structure does not explain the response",
    "wide_ci": "a parameter's 95 % interval is wider than the parameter itself",
    "gain_sign_wrong": "the model's gain has the opposite sign of the step's response",
    "closed_loop_suspected": "the input follows the output: the log looks closed-loop, not "
                             "a step test",
    "gain_inconsistent": "the events' gains disagree beyond their uncertainty: the plant is "
                         "not linear (or not time-invariant) over the log",
    "validation_misfit": "the model misses the events it did not see by much more than the "
                         "noise: the plant does not behave the same way over the whole log",
    "direction_asymmetry": "steps up and steps down give different gains",
    "no_usable_model": "every model the methods gave is unreliable: none is recommended",
    "no_integrating_evidence": "an integrating model of a record whose responses settle: "
                               "no window shows a ramp as long as they show the settling",
    "starts_mid_transient": "the output is moving at the start while the input is constant: "
                            "a step just before the first row (declare initial_input)",
    "check_failed": "a check could not be made on this model (a numerical failure): the "
                    "verdict lacks it",
    "oscillation_unmodelled": "the step's response overshoots and comes back (an "
                              "oscillation above the noise) and the model cannot: it misses "
                              "a lightly damped mode",
    "outlier_samples": "single output samples far off their neighbours (sensor glitches) "
                       "were replaced by their neighbours' median for the analysis",
    "zero_static_gain": "a step's response moves well above the noise and comes back to "
                        "where it started: no structure of the table represents it",
}

SEVERITY_ORDER = VERDICTS  # a flag's severity forces at least that verdict

#: Validation NRMSE fit below this (percent) is a poor fit (half the variation unexplained).
POOR_FIT_PERCENT = 50.0
#: A refined model that has reached less than this share of its final value by the end of
#: its window extrapolates its gain (the 95 % settling of a step response): information
#: above :data:`MOSTLY_SETTLED` (the gain is mostly seen, the rest is the model's own
#: extrapolation and in its interval), a warning below.
SETTLED_SHARE = 0.95
MOSTLY_SETTLED = 0.8
#: A model that explains less than this share (NRMSE fit, percent) of its own event's
#: variation is not a model of the data (unreliable); a misfit beyond the noise alone is a
#: warning (a quantised or very smooth signal has a tiny noise and a large ratio).
UNRELIABLE_FIT_PERCENT = 50.0
#: Interval half-width above this fraction of |value| is "wide" (the sign is uncertain at 1).
WIDE_CI = 0.5
#: A wide parameter matters (a warning: the data do not determine the model) when the step
#: response's 95 % band over the window (a refinement's joint uncertainty; a reading's
#: parameter moved to an end of its interval) is wider than this share of the response;
#: below, it is information (the response is determined).
MATERIAL = 0.1
#: A half-width beyond this many times the value is an interval without ends.
UNBOUNDED_WIDTH = 100.0
#: A drift before the step above this share of the step's change biases the gain visibly,
#: when it is beyond this many standard errors of a straight line through noise of the
#: baseline's own colour (slow noise wanders like a drift).
BASELINE_DRIFT = 0.02
BASELINE_SIGMAS = 4.0


def verdict_of(flags: tuple[Flag, ...] | list[Flag]) -> str:
    """The worst severity among ``flags``, ``info`` not counted ("ok" when there is none
    else)."""
    worst = 0
    for f in flags:
        if f.severity != "info":
            worst = max(worst, SEVERITY_ORDER.index(f.severity))
    return SEVERITY_ORDER[worst]


def grade(result: RecordResult, workers: Workers | None = None) -> RecordResult:
    """``result`` with a verdict and flags on every ok fit (pure); ``workers``: for a long
    record's many fits (:mod:`pipeline.parallel`)."""
    if not result.ok or result.record is None:
        return result
    shared = record_flags(result)
    todo = [f for f in result.fits if f.ok and f.model is not None]
    n = result.record.n_samples
    pool = worth_spreading(workers, n, len(todo), record_samples=n)
    own = iter(spread(pool, _own_flags, result, todo))
    fits = []
    for f in result.fits:
        if not f.ok or f.model is None:
            fits.append(f)
            continue
        flags = next(own) + shared
        fits.append(replace(f, flags=flags, verdict=verdict_of(flags)))
    return replace(result, fits=fits, flags=shared)


def _own_flags(result: RecordResult, fit: Fit) -> tuple[Flag, ...]:
    """:func:`fit_flags` as a tuple (a task of :func:`pipeline.parallel.spread`)."""
    return tuple(fit_flags(fit, result))


def no_usable_model(result: RecordResult, best: Fit) -> Flag:
    """The record-level flag when the best model left is unreliable: why (its flags)."""
    why = "; ".join(f"{f.code}: {f.message}" for f in best.flags if f.severity == "unreliable")
    return Flag("no_usable_model", f"No model is usable: the best of them ({best.method}, "
                f"{best.model.text(3)}) is unreliable - {why}", {"method": best.method},
                severity="unreliable")


def record_verdict(res: RecordResult) -> str:
    """"failed" for a record that could not be analysed, else the answer's verdict (with
    the record-level flags), "unreliable" when there is no model at all."""
    if not res.ok:
        return "failed"
    fit = res.recommended
    if fit is None:
        return "unreliable"
    return fit.verdict or verdict_of(fit.flags + res.flags)


# -- record level ------------------------------------------------------------------------

#: The output's change before the first event, as a share of the largest step response
#: (and in noise sigmas), beyond which the record starts in the middle of a transient: a
#: response that large is no wander of the noise, and its curvature is no noise colour
#: (a line's standard error from its residuals would count the transient as noise).
START_DRIFT = 0.1
START_SIGMAS = 10.0
#: A baseline whose scatter about its straight line is within this many noise sigmas is a
#: steady ramp (an integrating process off its balance point), not a transient.
STEADY_RAMP_SCATTER = 3.0


def _starts_mid_transient(result: RecordResult) -> Flag | None:
    """The output drifting before the first event while the input is constant, and no
    ``initial_input`` declared: the record starts inside the response to a step taken
    just before its first row, which segmentation cannot see (DaISy's first 6 -> 9 V)."""
    rec, events = result.record, result.events
    if rec.initial_input is not None or not events or events[0].i_start < 10:
        return None
    first = events[0]
    t, y = rec.t[: first.i_start], rec.y[: first.i_start]
    drift, _, scatter = baseline_drift(t, y, first.noise)
    largest = max(abs(e.y_ss - e.y0) for e in events)
    if drift <= max(START_SIGMAS * first.noise, START_DRIFT * largest):
        return None
    if scatter <= STEADY_RAMP_SCATTER * max(first.noise, 1e-300):
        return None  # a straight line: a steady ramp (an integrator off its balance), no transient
    u0 = float(rec.u[0])
    return Flag("starts_mid_transient", f"The record starts with the output moving (by "
                f"{drift:.3g}{output_unit(rec)} over the {_t(float(t[-1] - t[0]), rec)} "
                f"before the first event) while the input holds {u0:.4g}: the input "
                f"probably stepped to {u0:.4g} just before the first row. Declare the level "
                "it came from as initial_input to identify that step too.",
                {"drift": drift, "input": u0})


def _outlier_samples(result: RecordResult) -> Flag | None:
    """The output's single-sample outliers the analysis replaced
    (:mod:`pipeline.outliers`), named with their rows and values (information: the fits
    did not see them)."""
    rec = result.record
    if not rec.outliers:
        return None
    shown = "; ".join(f"t = {_t(float(rec.t[i]), rec)} reads {read:.4g} where its "
                      f"neighbours read {used:.4g}" for i, read, used in rec.outliers[:3])
    more = f" and {len(rec.outliers) - 3} more" if len(rec.outliers) > 3 else ""
    n = len(rec.outliers)
    return Flag("outlier_samples", f"{n} output sample{'s' if n > 1 else ''} far off "
                f"{'their' if n > 1 else 'its'} neighbours (a sensor glitch: {shown}{more}) "
                f"{'were' if n > 1 else 'was'} replaced by the neighbours' running median "
                "for the analysis; the fits did not see "
                f"{'them' if n > 1 else 'it'}.",
                {"samples": n, "first_time": float(rec.t[rec.outliers[0][0]]),
                 "first_value": rec.outliers[0][1]}, severity="info")


def _zero_static_gain(result: RecordResult) -> Flag | None:
    """A step whose output moves far above the noise and comes back to where it started
    (no final change, :meth:`pipeline.events.EventData.excursion`): an acceleration, a
    derivative or a washout, which no structure in the table (every one has a nonzero
    static gain or integrates) represents (issue 27 item 6). The largest such event."""
    rec, found = result.record, []
    for ev in result.events:
        if ev.kind != "step" or abs(ev.y_ss - ev.y0) > 3 * ev.noise or ev.noise <= 0:
            continue
        peak = EventData.from_event(rec, ev).excursion()
        if peak > MOVED_SIGMAS * ev.noise:
            found.append((peak / ev.noise, peak, ev))
    if not found:
        return None
    ratio, peak, ev = max(found, key=lambda f: f[0])
    return Flag("zero_static_gain", f"After the step at t = {_t(ev.t0, rec)} the output moves "
                f"by up to {peak:.3g}{output_unit(rec)} ({ratio:.0f} times the noise) "
                f"and comes back to where it started (a final change of "
                f"{ev.y_ss - ev.y0:.3g}): a response with zero static gain (an acceleration, "
                "a derivative, a washout), which no structure in the table represents; "
                + (f"{len(found)} step(s) do so. " if len(found) > 1 else "")
                + "Log the quantity it is the rate of, or identify it elsewhere.",
                {"event": ev.index, "excursion": peak, "events": len(found)})


def record_flags(result: RecordResult) -> tuple[Flag, ...]:
    """Findings about the whole log (attached to every fit)."""
    out = []
    for check in (_outlier_samples, _starts_mid_transient, _zero_static_gain):
        found = check(result)
        if found is not None:
            out.append(found)
    cl = closed_loop_flag(result.record, result.events)
    if cl is not None:
        out.append(cl)
    if result.consistency is not None:
        units = result.record.units
        unit = f"{units['output']}/{units['input']}" if units.get("output") and \
            units.get("input") else ""
        out.extend(gain_flags(list(result.consistency.estimates), unit))
    return tuple(out)


# -- fit level ---------------------------------------------------------------------------

def fit_flags(fit: Fit, result: RecordResult) -> list[Flag]:
    """The flags of one ok fit (see :data:`FLAGS`)."""
    rec = result.record
    ev = result.events[fit.event]
    checks = (_unsettled, _baseline, _below_sample_time, _delay_clipped, _fit_quality,
              _gain_sign, _wide_ci, _overshoot_in_noise, _undershoot_unmodelled)
    floor = fit_floor(fit, result)
    flags = [_checked(check, fit, ev, rec) for check in checks]
    flags += [_checked(_misfit, fit, ev, rec, floor),
              _checked(validation_misfit, fit, result, floor),
              _checked(_integrating_evidence, fit, result),
              _checked(oscillation_unmodelled, fit, result)]
    return [f for f in flags if f is not None]


def _checked(check, fit: Fit, *args) -> Flag | None:
    """``check(fit, *args)``; a check that fails (a numerical corner no test met) is a
    ``check_failed`` warning, never the end of the record's analysis."""
    try:
        return check(fit, *args)
    except Exception as exc:  # one check must not lose the record's other fits
        return Flag("check_failed", f"The check {check.__name__.strip('_')} could not be "
                    f"made ({type(exc).__name__}: {exc}); the verdict lacks it.",
                    {"check": check.__name__.strip("_")})


def settling_evidence(events: list[Event]) -> tuple[float, float]:
    """``(longest window whose step response settles, longest whose response ramps or
    shifts its level)``, in seconds, as segmentation classified them: a response seen
    decelerating towards a level over a longer window than any ramp was watched is
    self-regulating (a short window of a slow lag looks like a ramp; an integrator's
    ramps stay ramps however long they are watched)."""
    settle = max((e.t_end - e.t0 for e in events if e.kind == "step"
                  and e.response == "settling"), default=0.0)
    ramp = max((e.t_end - e.t0 for e in events if e.response in ("ramp", "level_shift")),
               default=0.0)
    return settle, ramp


def _integrating_evidence(fit: Fit, result: RecordResult) -> Flag | None:
    """An integrating model where the record's responses say self-regulating
    (:func:`settling_evidence`): a warning, and the recommendation passes it over."""
    if not fit.model.integrating:
        return None
    settle, ramp = settling_evidence(result.events)
    if settle <= ramp:
        return None
    rec = result.record
    return Flag("no_integrating_evidence", f"An integrating model, but the record's step "
                f"responses settle (over a window of {_t(settle, rec)}) and no window shows "
                + (f"a ramp that long (the longest: {_t(ramp, rec)})" if ramp else "a ramp")
                + ": the process is self-regulating, and this model drifts away from the "
                "data beyond its window.", {"settling_window": settle, "ramp_window": ramp})


def _unit(name: str, rec: Record, fit: Fit) -> str:
    p = PARAMETERS.get(name)
    u = p.unit(rec.units, integrating=fit.model.spec.integrating) if p else ""
    return f" {u}" if u else ""


def _t(seconds: float, rec: Record) -> str:
    """A duration in the user's time unit, e.g. ``"12.5 min"``."""
    unit = rec.units.get("time") or "s"
    return f"{in_time_unit(seconds, rec.units.get('time')):.3g} {unit}"


def _unsettled(fit: Fit, ev: Event, rec: Record) -> Flag | None:
    """Graphical: the window did not settle (segmentation). Refined: the model itself has
    not reached :data:`SETTLED_SHARE` of its final value by the window's end, so its gain
    is an extrapolation (an integrating model never settles: no flag)."""
    if ev.kind != "step":
        return None
    window = float(rec.t[ev.i_end - 1] - ev.t0)
    if fit.is_refined:
        if fit.model.spec.integrating or fit.model.K == 0:
            return None
        share = float(fit.model.unit_step(np.array([window]))[0] / fit.model.K)
        if share >= SETTLED_SHARE:
            return None
        mostly = share >= MOSTLY_SETTLED
        return Flag("unsettled", f"By the end of the window ({_t(window, rec)} after the "
                    f"step) the model has reached {share:.0%} of its final value: the gain is "
                    + ("mostly seen, the rest extrapolated by the model (within its "
                       "interval)." if mostly else "extrapolated beyond the data."),
                    {"window": window, "share": share},
                    severity="info" if mostly else "warning")
    if ev.settled:
        return None
    K = fit.model.K
    return Flag("unsettled", f"The window ends {_t(window, rec)} after the step, before the "
                f"output settles: the gain K = {K:.4g}{_unit('K', rec, fit)} is read from a "
                "level that is still moving (a lower bound of the true gain).",
                {"window": window, "K": K})


def _baseline(fit: Fit, ev: Event, rec: Record) -> Flag | None:
    """A trend in the stretch before t0 larger than its noise and than BASELINE_DRIFT of the
    change (a refined fit that carried or estimated the initial state is exempt)."""
    if fit.is_refined and not fit.refinement.at_rest:
        return None
    if fit.model.spec.integrating:  # read against the baseline's drift line, not a level
        return None
    t, y = rec.t[ev.i_base:ev.i_start], rec.y[ev.i_base:ev.i_start]
    dy = ev.y_ss - ev.y0
    if t.size < 10 or dy == 0:
        return None
    drift, se, _ = baseline_drift(t, y, ev.noise)  # its error bar knows the noise's colour
    if drift <= max(BASELINE_SIGMAS * se, BASELINE_DRIFT * abs(dy)):
        return None
    return Flag("baseline_not_steady", f"The output drifts by {drift:.3g}"
                f"{output_unit(rec)} ({drift / abs(dy):.0%} of the step's change) over the "
                f"{_t(float(t[-1] - t[0]), rec)} before the step: the baseline is not steady, "
                "so y0 and "
                "the gain are biased.", {"drift": drift, "share": drift / abs(dy)})


def _below_sample_time(fit: Fit, ev: Event, rec: Record) -> Flag | None:
    dt = rec.sample_time or float(np.median(np.diff(rec.t)))
    p = fit.model.params
    times = {k: abs(float(p[k])) for k in p if PARAMETERS.get(k) and
             PARAMETERS[k].kind == "time" and k != "delay" and float(p[k]) != 0.0}
    if "wn" in p and p["wn"] > 0:
        times["1/wn"] = 1.0 / float(p["wn"])
    fast = {k: v for k, v in times.items() if v < dt}
    if not fast:
        return None
    k, v = min(fast.items(), key=lambda kv: kv[1])
    return Flag("dynamics_below_sample_time", f"{k} = {_t(v, rec)} is shorter than the "
                f"sample time {_t(dt, rec)}: the data only say this part of the response is faster "
                "than the sampling, not how fast.", {"parameter": k, "value": v,
                                                     "sample_time": dt})


def _delay_clipped(fit: Fit, ev: Event, rec: Record) -> Flag | None:
    d = fit.diagnostics
    raw = next((d[k] for k in ("delay_computed", "delay_implied")
                if isinstance(d.get(k), int | float)), None)
    if raw is None or raw >= 0 or fit.model.delay > 0:
        return None
    return Flag("delay_clipped", f"The method computed a negative dead time "
                f"({_t(float(raw), rec)}) "
                "and set it to 0: the response starts faster than the model's shape allows.",
                {"delay_computed": float(raw)})


def _fit_quality(fit: Fit, ev: Event, rec: Record) -> Flag | None:
    fp = fit.metrics.get("fit_percent", math.nan)
    if not math.isfinite(fp):
        return None
    if fp < 0:
        return Flag("negative_fit", f"Validation fit {fp:.0f} %: on the events it did not "
                    "see, the model is worse than a constant at the mean.",
                    {"fit_percent": fp}, severity="unreliable")
    if fp < POOR_FIT_PERCENT:
        return Flag("poor_fit", f"Validation fit {fp:.0f} %: the model explains less than "
                    "half of the validation data's variation.", {"fit_percent": fp})
    return None


def _misfit(fit: Fit, ev: Event, rec: Record, floor: float) -> Flag | None:
    """The error on the model's own event (:func:`own_rms`) against the noise. Beyond
    :data:`MISFIT_RATIO` noise sigmas and :data:`MISFIT_RATIO` times the best refinement's
    error on the same data (:func:`fit_floor`) a warning: the residuals are structure;
    beyond the noise but within the best refinement's, information: the noise is slower
    than its estimate from the differences says, or every structure misses the same slow
    part. Unreliable when the model explains less than :data:`UNRELIABLE_FIT_PERCENT` of
    the window's variation (NRMSE fit)."""
    rms = own_rms(fit)
    if not math.isfinite(rms) or ev.noise <= 0:
        return None
    ratio = rms / ev.noise
    if ratio <= MISFIT_RATIO:
        return None
    spread = float(np.std(rec.y[ev.i_start:ev.i_end]))
    fit_pct = 100.0 * (1.0 - rms / spread) if spread > 0 else math.nan
    bad = not fit_pct >= UNRELIABLE_FIT_PERCENT
    beyond = not math.isfinite(floor) or rms > MISFIT_RATIO * floor
    values = {"misfit_ratio": ratio, "rms": rms, "noise": ev.noise, "fit_percent": fit_pct,
              "best_rms": floor if math.isfinite(floor) else None}
    if not bad and not beyond:
        return Flag("residuals_not_white", f"On its own event the model misses the data by "
                    f"{ratio:.1f} times the noise estimate (RMS {rms:.3g}"
                    f"{output_unit(rec)}), as the best structure does ({floor:.3g}): the "
                    "noise is slower than its estimate, or every structure misses the same "
                    "slow part.", values, severity="info")
    return Flag("residuals_not_white", f"On its own event the model misses the data by "
                f"{ratio:.1f} times the noise level (RMS {rms:.3g}"
                f"{output_unit(rec)}, fit {fit_pct:.0f} %): the residuals are structure, "
                "not noise" + (" - this is not a model of the data." if bad else "."),
                values, severity="unreliable" if bad else "warning")


def _gain_sign(fit: Fit, ev: Event, rec: Record) -> Flag | None:
    """A self-regulating model whose gain has the opposite sign of the step's response."""
    if ev.kind != "step" or fit.model.spec.integrating or ev.u_ss == ev.u0 \
            or abs(ev.y_ss - ev.y0) <= 3 * ev.noise:
        return None
    seen = (ev.y_ss - ev.y0) / (ev.u_ss - ev.u0)
    if fit.model.K * seen > 0:
        return None
    return Flag("gain_sign_wrong", f"The model's gain ({fit.model.K:.3g}) has the opposite "
                f"sign of the step's response ({seen:+.3g}{_unit('K', rec, fit)}): the model is "
                "wrong.", {"K": fit.model.K, "step_gain": seen}, severity="unreliable")


def _wide_ci(fit: Fit, ev: Event, rec: Record) -> Flag | None:
    """A parameter whose 95 % half-width is beyond :data:`WIDE_CI` of its value: a warning
    when it matters (the step response's 95 % band over the window is wider than
    :data:`MATERIAL`: :func:`response_band` from a refinement's covariance, else
    :func:`response_change` for a reading; the gain, or an interval without ends, always
    matters), else information (the data determine the response, not that parameter)."""
    wide = {}
    for k, (lo, hi) in fit.ci95.items():
        v = float(fit.model.params.get(k, math.nan))
        if k == "delay" or not (math.isfinite(v) and v != 0 and lo is not None and
                                hi is not None):
            continue
        half = (float(hi) - float(lo)) / 2.0
        if half > WIDE_CI * abs(v):
            wide[k] = half / abs(v)
    if not wide:
        return None
    horizon = float(rec.t[ev.i_end - 1] - ev.t0)
    band = response_band(fit, horizon)
    if band is not None:  # the parameters' joint uncertainty, correlations included
        change = dict.fromkeys(wide, band)
    else:
        change = {k: response_change(fit, k, horizon) for k in wide}
    # the gain is the model's main number, and an interval without ends (a lag that may
    # be anything) is no determined parameter whatever the response does in the window
    material = {k: c for k, c in change.items() if not c <= MATERIAL or k == "K"
                or wide[k] > UNBOUNDED_WIDTH}
    k = max(material or wide, key=(material or wide).get)
    w = wide[k]
    size = (f"{w:.0%} of its value" if w < 10 else f"{w:.0f} times its value" if w < 1e6
            else f"{w:.2g} times its value")
    values = {"parameter": k, "relative_half_width": w, "response_change": change[k]}
    over = "with the parameters' joint 95 % uncertainty" if band is not None else \
        "over its interval"
    if not material:
        return Flag("wide_ci", f"The 95 % interval of {k} is ±{size}, but {over} the step "
                    f"response moves by at most ±{change[k]:.1%}: the data determine the "
                    f"response, not {k}.", values, severity="info")
    return Flag("wide_ci", f"The 95 % interval of {k} is ±{size}: the data do not determine "
                "it" + (f", and {over} the step response moves by ±{change[k]:.0%}."
                        if math.isfinite(change[k]) else "."), values)


def _overshoot_in_noise(fit: Fit, ev: Event, rec: Record) -> Flag | None:
    p = fit.model.params
    if fit.model.structure != "second_order" or p["zeta"] >= 1 or ev.kind != "step":
        return None
    z = float(p["zeta"])
    M = math.exp(-z * math.pi / math.sqrt(1.0 - z * z))
    peak = M * abs(ev.y_ss - ev.y0)
    if peak > 3.0 * ev.noise:
        return None
    return Flag("overshoot_within_noise", f"The model's overshoot ({peak:.3g}"
                f"{output_unit(rec)}, zeta = {z:.2g}) is within three noise sigmas "
                f"({ev.noise:.3g}): the data do not show that oscillation (the response is "
                "the same within the noise).",
                {"overshoot": peak, "noise": ev.noise, "zeta": z}, severity="info")


def _undershoot_unmodelled(fit: Fit, ev: Event, rec: Record) -> Flag | None:
    """The data move the wrong way first (an inverse response) and the model cannot: a
    structure without a right-half-plane zero misses the dip whatever its fit says."""
    if ev.kind != "step" or float(fit.model.params.get("Tz", 0.0)) < 0:
        return None
    from ..events import EventData
    from ..methods import moving_the_other_way, undershoot

    data = EventData.from_event(rec, ev)
    u = undershoot(data)
    if u is None or moving_the_other_way(data) is not None:
        return None
    return Flag("residuals_not_white", f"The output first moves the wrong way (by "
                f"{u['depth']:.0%} of its change, {_t(u['t'], rec)} after the step) and a "
                f"{fit.model.structure.replace('_', ' ')} model cannot: its residuals are "
                "structure, not noise (an inverse response needs a zero, Tz < 0).",
                {"undershoot": u["depth"], "t": u["t"]})

