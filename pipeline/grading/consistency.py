"""Per-event consistency: is one linear time-invariant model right for the whole log?

Every step is identified on its own (:class:`EventEstimate`: its gain and dominant time
constant with 95 % intervals, at its operating point and time). Then:

* ``gain_inconsistent`` - the gains disagree beyond their intervals: a chi-square test of
  the gains around their weighted mean (significant at 0.1 %) *and* a spread that matters
  (the extreme gains differ by more than :data:`GAIN_SPREAD` of their mean), so tiny but
  significant differences on very clean data are not alarms;
* ``direction_asymmetry`` - steps up and steps down give different gains at the same level
  (the gains regressed on the step's mid-level and its direction; same two conditions);
* the static map - the settled (asymptotic) output against the input level, fitted with a
  line and a quadratic; "clearly not a line" when the quadratic halves the residual and
  its curvature is significant (an F test at 0.1 %), as for a heater whose power goes
  with u^2 (a Hammerstein plant: tests/test_consistency_e2e.py).

:func:`event_estimates` identifies each step on its own: its dominant time constant by
least squares with the record's recommended structure (first order when that has no time
constant to compare; the state carried where the output was still moving,
:func:`pipeline.methods.event_fit`), its gain by :func:`step_gains` (one gain per step at the
recommended dynamics, the steps' responses superposed); the rest are pure statistics.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from ..events import Event, EventData
from ..fit import Fit, Flag
from ..methods import event_fit, identify
from ..models import PARAMETERS, STRUCTURES, ProcessModel
from ..parallel import Workers, spread, worth_spreading
from ..record import Record
from ..refine import MIN_DOF, RefineOptions
from ..results import Consistency, EventEstimate, Recommendation, RecordResult, StaticMap
from ..simulation import memory, simulate
from ..uncertainty import residual_variance, t_quantile, variance_factor
from . import superposition
from .superposition import Column

#: The extreme per-event gains must differ by more than this share of their mean.
GAIN_SPREAD = 0.10
#: Significance of the consistency tests (a false alarm in one log of a thousand).
ALPHA = 1e-3
#: The per-event structure when the recommended one has no lag to compare (its gain and
#: time constant are what the report compares).
FALLBACK = "first_order"
#: The time constants a dominant one is chosen from (the largest): the lags of the table.
LAGS = tuple(p.name for p in PARAMETERS.values() if p.lag)
#: With this many step events or more, consistency is checked unless switched off.
AUTO_MIN_STEPS = 3


def per_step(result: RecordResult, recommendation: Recommendation | None,
             states: list[str], *, setting: bool | None = None,
             options: RefineOptions | None = None,
             workers: Workers | None = None) -> Consistency | None:
    """Each step of ``result`` on its own (:func:`event_estimates`) and their static map,
    when :func:`wanted`: with the recommended structure where it has a lag and settles
    (:func:`per_event_structure`), the gains at the recommended model's dynamics."""
    if not wanted(result.events, setting):
        return None
    chosen = result.fit(recommendation.method, recommendation.event,
                        recommendation.events) if recommendation else None
    structure = per_event_structure(chosen.model.structure if chosen else None)
    reference = chosen.model if chosen and chosen.model.structure == structure else None
    est = event_estimates(result.record, result.events, states, structure, fits=result.fits,
                          reference=reference, options=options, workers=workers)
    return Consistency(tuple(est), static_map(est))


def wanted(events: list[Event], setting: bool | None) -> bool:
    """``setting``, or by default: with :data:`AUTO_MIN_STEPS` step events or more."""
    if setting is not None:
        return setting
    return sum(e.kind == "step" for e in events) >= AUTO_MIN_STEPS


def per_event_structure(structure: str | None) -> str:
    """The structure each step is identified with: the recommended one when it has a lag
    (T, T1, T2) and settles, else first order."""
    if structure and structure in STRUCTURES and not STRUCTURES[structure].integrating \
            and any(p in STRUCTURES[structure].params for p in LAGS):
        return structure
    return FALLBACK


def event_estimates(record: Record, events: list[Event], states: list[str],
                    structure: str = FALLBACK, *, fits: list[Fit] = (),
                    reference: ProcessModel | None = None,
                    options: RefineOptions | None = None,
                    workers: Workers | None = None) -> list[EventEstimate]:
    """Every settling step event on its own: its dominant time constant (with interval)
    from the refinement of ``structure`` on that event (reusing a fit the analysis made),
    its gain (with interval) from :func:`step_gains` at the dynamics of ``reference`` (the
    recommended model; else of the first event's own fit)."""
    method = f"lsq_{structure}"
    steps = [ev for ev in events
             if ev.kind == "step" and ev.response == "settling" and ev.i_end - ev.i_start >= 10]
    made: dict[int, Fit] = {}
    for f in fits:  # the analysis's own fit of the structure on an event, when it made one
        if f.method == method and not f.events:
            made.setdefault(f.event, f)
    todo = [(ev.index, tuple(f.model for f in fits if f.ok and f.event == ev.index))
            for ev in steps if ev.index not in made]
    pool = worth_spreading(workers, sum(events[i].i_end - events[i].i_start for i, _ in todo),
                           len(todo), record_samples=record.n_samples)
    made.update(zip((i for i, _ in todo), spread(
        pool, _own_fit, (record, events, states, method, options), todo), strict=True))
    own: dict[int, Fit] = {ev.index: made[ev.index] for ev in steps if made[ev.index].ok}
    if not own:
        return []
    gains = step_gains(record, events, reference or next(iter(own.values())).model)
    out = []
    for i, fit in own.items():
        lags = [p for p in LAGS if p in fit.model.params and fit.ci95.get(p)]
        if i not in gains or not lags:
            continue
        name = max(lags, key=lambda p: float(fit.model.params[p]))
        if None in fit.ci95[name]:
            continue
        K, K_se, K_ci, y_before, y_after = gains[i]
        ev = events[i]
        out.append(EventEstimate(i, ev.t0, ev.u0, ev.u_ss, y_before, y_after, K, K_ci,
                                 float(fit.model.params[name]), tuple(fit.ci95[name]),
                                 fit.refinement.state_text if fit.is_refined else "", K_se))
    return out


def _own_fit(shared: tuple, task: tuple[int, tuple[ProcessModel, ...]]) -> Fit:
    """Refinement ``method`` of one step on its own, started from the analysis's models
    of that event and its first-order and Viteckova readings (a task of
    :func:`pipeline.parallel.spread`)."""
    record, events, states, method, options = shared
    i, starts = task
    data = EventData.from_event(record, events[i])
    models = [*starts, *(g.model for m in ("first_order", "viteckova1")
                         if (g := identify(data, m)).ok)]
    return event_fit(record, events, i, method, models=models, states=states, options=options)


def step_gains(record: Record, events: list[Event], shape: ProcessModel
               ) -> dict[int, tuple[float, float, tuple[float, float], float, float]]:
    """Each step's own gain at shared dynamics: ``{event: (K, its standard error, 95 %
    interval, asymptote before, asymptote after)}``.

    The input is split into its events' increments, ``u = u_start + sum_j d_j`` (``d_j``
    what event j adds, held after its window), and the output regressed on the unit-gain
    responses of ``shape`` to each: ``y = c + sum_j K_j (G * d_j)``, linear in the gains.
    Every step keeps its own gain while its response goes on under the later ones, which
    is exact for a static nonlinearity before linear dynamics (a Hammerstein plant: a
    lamp's power ~ u^2 heating a plate). Intervals from the residuals with their
    coloured-noise factor (:func:`pipeline.uncertainty.covariance`); solved without
    the dense samples x events matrix by :mod:`pipeline.grading.superposition`."""
    t, u, y = record.t, record.u, record.y
    unit = ProcessModel(shape.structure, {**shape.params, "K": 1.0})
    starts = [e.i_start for e in events] + [t.size]
    ref = record.initial_input if record.initial_input is not None and starts[0] == 0 \
        else float(u[max(starts[0] - 1, 0)])
    dt = record.sample_time
    mem = memory(unit, dt) if dt is not None else None

    def response(a: int, b: int, stop: int, before: float):
        def make() -> np.ndarray:  # simulated when the solver needs it (twice: memory)
            d = np.empty(stop - a)
            d[: b - a] = u[a:b] - before
            d[b - a:] = d[b - a - 1] if b > a else 0.0
            return simulate(unit, t[a:stop], d, 0.0, 0.0, dt=dt) if stop > a else d
        return make

    cols = []
    for j in range(len(events)):
        a, b = starts[j], starts[j + 1]
        before = ref if j == 0 else float(u[a - 1])
        # the column is 0 before its event, settled on the held increment from `memory`
        # samples after its window on: only [a, stop) is simulated
        stop = t.size if mem is None else min(t.size, b + mem)
        delta = float(u[b - 1] - before) if stop > a and b > a else 0.0  # d[-1] of make()
        cols.append(Column(a, stop, None, delta, response(a, b, stop, before)))
    delta = [c.delta for c in cols]
    sol = superposition.solve(cols, y)
    coef, e, p = sol.coef, sol.residuals, len(cols) + 1
    f = variance_factor(e)
    var = residual_variance(e, p, f) * f * sol.unscaled
    q = t_quantile(max(t.size / f - p, MIN_DOF))
    out, level = {}, float(coef[0])
    for j, ev in enumerate(events):
        K, se = float(coef[j + 1]), float(math.sqrt(max(var[j + 1], 0.0)))
        after = level + K * delta[j]
        if ev.kind == "step" and delta[j] != 0:
            out[ev.index] = (K, se, (K - q * se, K + q * se), level, after)
        level = after
    return out


def gain_flags(estimates: list[EventEstimate], unit: str = "") -> list[Flag]:
    """``gain_inconsistent`` and ``direction_asymmetry`` from per-event gains."""
    out = []
    est = [e for e in estimates if math.isfinite(e.K) and e.K_se > 0]
    if len(est) < 2:
        return out
    K = np.array([e.K for e in est])
    se = np.array([e.K_se for e in est])
    w = 1.0 / se**2
    mean = float(np.sum(w * K) / np.sum(w))
    chi2 = float(np.sum(w * (K - mean) ** 2))
    p = float(stats.chi2.sf(chi2, len(est) - 1))
    spread = float((K.max() - K.min()) / abs(mean)) if mean else math.inf
    u = f" {unit}" if unit else ""
    if p < ALPHA and spread > GAIN_SPREAD:
        listing = ", ".join(f"{e.K:.3g}" for e in est)
        out.append(Flag(
            "gain_inconsistent",
            f"The steps' own gains disagree beyond their uncertainty: {listing}{u} "
            f"(events {', '.join(str(e.index) for e in est)}; extremes {spread:.0%} apart, "
            f"chi-square p = {p:.1g}). No single linear model fits every operating point: "
            "use the model near the level you will control at, or a gain schedule.",
            {"gains": listing, "spread": spread, "p": p, "mean": mean}))
    asym = _direction(est, mean, u)
    if asym is not None:
        out.append(asym)
    return out


def _direction(est: list[EventEstimate], mean: float, u: str) -> Flag | None:
    """``direction_asymmetry``: the gains regressed on the step's mid-level and its
    direction, ``K = a + b m + c d`` (``d`` +1/2 up, -1/2 down; weighted by the gains'
    errors), so a gain that only follows the level (a static curve, where steps up and
    down sit at different levels) is not called asymmetric; flagged when ``c`` is
    significant and more than :data:`GAIN_SPREAD` of the mean gain."""
    if sum(e.up for e in est) < 1 or sum(not e.up for e in est) < 1 or len(est) < 4:
        return None
    X = np.array([[1.0, 0.5 * (e.u0 + e.u1), 0.5 if e.up else -0.5] for e in est])
    K = np.array([e.K for e in est])
    w = np.array([1.0 / e.K_se for e in est])
    coef, *_ = np.linalg.lstsq(X * w[:, None], K * w, rcond=None)
    cov = np.linalg.pinv((X * w[:, None]).T @ (X * w[:, None]))
    c, se_c = float(coef[2]), float(math.sqrt(max(cov[2, 2], 0.0)))
    p = float(2 * stats.norm.sf(abs(c) / se_c)) if se_c > 0 else 1.0
    rel = abs(c) / abs(mean) if mean else math.inf
    if not (p < ALPHA and rel > GAIN_SPREAD):
        return None
    up_k = float(np.mean([e.K for e in est if e.up]))
    down_k = float(np.mean([e.K for e in est if not e.up]))
    return Flag("direction_asymmetry",
                f"At the same level, steps up and steps down differ in gain by {c:+.3g}{u} "
                f"({rel:.0%} of the mean; steps up average {up_k:.3g}, down {down_k:.3g}, "
                f"p = {p:.1g}): the plant responds differently to increases and decreases.",
                {"difference": c, "p": p, "K_up": up_k, "K_down": down_k})


def static_map(estimates: list[EventEstimate]) -> StaticMap | None:
    """The input levels and asymptotic outputs of the steps (the first step's starting
    point included), a line and a quadratic through them. None with fewer than 4 levels
    (a quadratic through 3 points always fits)."""
    if not estimates:
        return None
    first = min(estimates, key=lambda e: e.t0)
    u = [first.u0] + [e.u1 for e in estimates]
    y = [first.y0] + [e.y_inf for e in estimates]
    ua, ya = np.array(u), np.array(y)
    if len(set(np.round(ua, 12))) < 4:
        return None
    line = np.polyfit(ua, ya, 1)
    quad = np.polyfit(ua, ya, 2)
    r1 = ya - np.polyval(line, ua)
    r2 = ya - np.polyval(quad, ua)
    n = ua.size
    ss1, ss2 = float(r1 @ r1), float(r2 @ r2)
    if ss2 <= 0:
        p = 0.0 if ss1 > 0 else 1.0
    else:
        F = (ss1 - ss2) / (ss2 / (n - 3))
        p = float(stats.f.sf(F, 1, n - 3)) if n > 3 else 1.0
    rms1, rms2 = math.sqrt(ss1 / n), math.sqrt(ss2 / n)
    nonlinear = p < ALPHA and rms2 < 0.5 * rms1
    return StaticMap(tuple(u), tuple(y), (float(line[1]), float(line[0])),
                     (float(quad[2]), float(quad[1]), float(quad[0])), rms1, rms2,
                     nonlinear, p)


def static_map_note(m: StaticMap | None, units: dict[str, str]) -> str | None:
    """A plain-words line for the report when the static map is clearly not a line."""
    if m is None or not m.nonlinear:
        return None
    a, b, c = m.quadratic
    yu = f" {units['output']}" if units.get("output") else ""
    return (f"The settled output is not a straight line of the input: y = {a:.4g} "
            f"{b:+.4g} u {c:+.4g} u^2 fits the step levels with RMS {m.rms_quadratic:.3g}{yu} "
            f"against {m.rms_line:.3g}{yu} for a line (curvature p = {m.p_curvature:.1g}).")
