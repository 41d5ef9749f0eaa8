"""Refinement of one event (the ``lsq_<structure>`` methods run on an event alone), and
the decision how its initial state is treated.

* :func:`refine_event` - one event's window (the baseline before ``t0`` and the window
  after it), started from the graphical methods' models and the dead time where the
  response leaves its noise band (:func:`band_exit`);
* :func:`initial_state` - "rest" when the baseline before the step is settled, else
  "estimated": the output is still moving there (the previous event did not settle, or
  the baseline drifts by more than its noise); :func:`structure_state` makes it "steady"
  for an integrating structure on a baseline segmentation measured as a straight ramp;
* :func:`mismatch` - why a structure cannot describe an event's response at all (a
  self-regulating model of a ramp or of a pulse's level shift, an integrating model of a
  response that settles); :func:`unchanged` - an event with no response to refine.

Estimating the state always would make the gain unidentifiable for a step at the first
samples of a window: after the dead time a first-order lag's step response and its free
response are the same exponential, and only the few samples before the step tell them
apart. So it is estimated only where the data say the plant was moving (MATLAB procest's
``InitialCondition`` choice, made from the data), and where the record holds an earlier
event that started at rest, :mod:`pipeline.refine.joint` carries the state from there instead
(the measured input since then drives it, and the same gain explains the tail).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..events import Event, EventData
from ..fit import InitialState, RefinementSummary
from ..models import STRUCTURES, ProcessModel
from ..record import Record
from ..signal import smooth
from ..uncertainty import variance_factor
from ..validate import fit_start
from .refinement import Refinement, RefineOptions, refine
from .search import candidate_starts, jumps

#: A baseline drift larger than this share of the step's output change counts as moving
#: (when it is also beyond 3 standard errors of the noise).
DRIFT_FRACTION = 0.01


def baseline_drift(t: np.ndarray, y: np.ndarray, noise: float
                   ) -> tuple[float, float, float]:
    """``(drift, standard error, scatter)`` of the output over the baseline ``t, y``: the
    straight-line change over it, its standard error, from the scatter about the line (at
    least ``noise``) and its colour (slow noise wanders like a drift: a white-noise error
    bar would call it one; :func:`pipeline.uncertainty.variance_factor`), and that
    scatter (a curve, not a line, when it is far above the noise). Zeros with fewer than
    four samples."""
    if y.size < 4:
        return 0.0, 0.0, 0.0
    tc = t - t[0]
    slope, icpt = np.polyfit(tc, y, 1)
    resid = y - (icpt + slope * tc)
    scatter = max(float(np.std(resid, ddof=2)), noise)
    se = scatter * math.sqrt(variance_factor(resid) / max(float(np.sum((tc - tc.mean())**2)),
                                                          1e-300))
    return abs(float(slope) * float(tc[-1])), se * float(tc[-1]), scatter


def baseline_moving(t: np.ndarray, y: np.ndarray, noise: float, dy: float) -> bool:
    """Whether the output drifts over the baseline ``t, y``: its drift
    (:func:`baseline_drift`) exceeds three standard errors and ``DRIFT_FRACTION`` of
    ``dy``."""
    drift, se, _ = baseline_drift(t, y, noise)
    return drift > max(3 * se, DRIFT_FRACTION * abs(dy))


def mismatch(structure: str, ev: Event | EventData) -> str | None:
    """Why ``structure`` cannot describe the event's response (None: it can), from what
    segmentation found (:mod:`pipeline.segmentation` step 6):

    * a self-regulating structure and a step whose output ramps without settling: its
      gain (the final change over the input change) does not exist (unless the step came
      on the tail of a previous response still settling, ``tail``: the output goes on
      moving that way, and a ramp test on the window is no evidence of an integrator,
      whose responses end on steady ramps, never on tails);
    * after a pulse, a self-regulating structure and an output that moves to a new level
      and stays, or an integrating one and an output back on its baseline;
    * an integrating structure and a step whose output settles at a new level
      (``settled``, not a ramp against the baseline's line): after a step an integrator
      ramps at ``K du`` unless the step brought the input exactly to its balance point,
      and then the output was ramping before it, which segmentation would have measured
      as a drift and the step's response as a ramp against it. Only a refinement with a
      free balance point could fit such a window (a ramp hidden in a short baseline,
      then a lag coming to rest): a coincidence, not a model.
    """
    integrating = STRUCTURES[structure].integrating
    if ev.kind == "impulse":
        if ev.response == "level_shift" and not integrating:
            return ("the output moves to a new level after the pulse and stays there (an "
                    "integrating process): a self-regulating model returns to its baseline")
        if ev.response == "settling" and ev.settled and integrating:
            return ("the output returns to its baseline after the pulse (a self-regulating "
                    "process): an integrating model would stay shifted by K times the area")
        return None
    if ev.response == "ramp" and not integrating and not ev.tail:
        return ("the output ramps without settling (an integrating process): a "
                "self-regulating model has no gain for it")
    if ev.response == "settling" and ev.settled and integrating:
        where = ("settles at a new level" if abs(ev.y_ss - ev.y0) > 3 * ev.noise else
                 "settles where it started")
        return (f"the output {where} after the step (a self-regulating "
                "process): an integrating model would go on ramping at K du, unless the "
                "input came exactly to its balance point and the output ramped before")
    return None


def unchanged(ev: EventData) -> str | None:
    """Why the event shows no response to refine (None: it does): a step whose output did
    not change by more than 3 noise standard deviations, a pulse without area or whose
    smoothed response never leaves them."""
    if ev.kind == "impulse":
        if ev.area == 0 or not math.isfinite(ev.area):
            return "the impulse has no area (the input did not leave its baseline)"
        r = ev.y[ev.i0:] - ev.y0
        peak = float(np.max(np.abs(smooth(r, ev.noise / max(float(np.max(np.abs(r))),
                                                               1e-300))))) if r.size else 0.0
        return None if peak > 3 * ev.noise else ("no measurable response to the pulse "
                                                  "(peak <= 3 sigma)")
    if ev.dy == 0 or not math.isfinite(ev.dy) or abs(ev.dy) <= 3 * ev.noise:
        return ev.unchanged_reason()
    return None


def initial_state(ev: EventData, previous_settled: bool | None = None) -> InitialState:
    """"rest" or "estimated" for an event (see the module docstring)."""
    i0 = ev.i0
    if previous_settled is False:
        return "estimated"
    if i0 < 4:
        return "rest"  # nothing before the step to judge by: assumed (e.g. a record start)
    moving = baseline_moving(ev.t[:i0], ev.y[:i0], ev.noise, ev.dy)
    return "estimated" if moving else "rest"


#: The response has left its noise band when it is this many noise standard deviations
#: (on noise-free data this share of the change) away from the baseline line, on this many
#: samples in a row.
BAND_SIGMAS, BAND_SHARE, BAND_RUN = 4.0, 0.02, 3


def band_exit(ev: EventData) -> float | None:
    """A dead time read off the data: the time after t0 at which the response (the output
    less the baseline line) first leaves its noise band, less half a sample (a jump seen
    at sample k came at a dead time in ((k-1) dt, k dt]); None if it never does. The
    band is :data:`BAND_SIGMAS` noise standard deviations (:data:`BAND_SHARE` of the
    change without noise), and the response must stay out for :data:`BAND_RUN` samples."""
    i = ev.i0
    tau = ev.t[i:] - ev.t0
    if tau.size < BAND_RUN + 1:
        return None
    r = ev.y[i:] - ev.y0 - ev.drift * tau
    out = np.abs(r) > (BAND_SIGMAS * ev.noise or BAND_SHARE * abs(ev.dy))
    run = np.convolve(out, np.ones(BAND_RUN, dtype=int), mode="valid") == BAND_RUN
    if not run.any():
        return None
    k = int(np.argmax(run))
    return max(float(tau[k]) - 0.5 * float(np.median(np.diff(tau))), 0.0)


def refine_event(ev: EventData, structure: str, *, models: Sequence[ProcessModel] | None = None,
                 state: InitialState | None = None, options: RefineOptions | None = None
                 ) -> Refinement:
    """Refine ``structure`` on one event: its baseline (:func:`pipeline.validate.fit_start`)
    and window, the model at rest at the event's input level ``u0`` or with its initial
    state estimated (``state``; None: decided by :func:`initial_state`), started from
    ``models`` (the graphical methods' readings; :mod:`pipeline.methods.lsq` passes them)
    and the dead time where the response leaves its noise band (:func:`band_exit`)."""
    models = [] if models is None else list(models)
    sl = slice(fit_start(0, ev.i0, ev.t.size), ev.t.size)
    span = float(ev.t[-1] - ev.t[sl.start])
    exit_ = band_exit(ev)
    starts = candidate_starts(structure, models, span, () if exit_ is None else (exit_,))
    args = (ev.t[sl], ev.u[sl], ev.y[sl], structure)
    kw = {"u_ref": ev.u0, "options": options,
          "initial_state": structure_state(structure, state or initial_state(ev), ev)}
    ref = refine(*args, starts=starts, **kw)
    if exit_ is not None and jumps(structure) and ref.mse > BASIN_RATIO * ev.noise**2:
        # the cost of a response that jumps at its dead time is discontinuous at every
        # sample: the search from the best-ranked starts can stop samples off it
        at_exit = [p for p in starts if p.get("delay") == exit_]
        again = refine(*args, starts=at_exit, **kw) if at_exit else ref
        ref = again if again.mse < ref.mse else ref
    return ref


#: A jumping response's fit error, in noise variances, beyond which its search is run
#: again from the starts at the dead time read off the data (:func:`band_exit`). Measured:
#: a lead-lag that jumps back (2(-2s+1)/(5s+1) e^-s, 2 % noise) stopped at a dead time of
#: 0.81 s in 1 seed of 10 (MSE 3.0 noise variances, its Tz 10 % off); from the dead time
#: read off the data it reached 1.00 s (1.005). The others fit within 1.05.
BASIN_RATIO = 1.5


def structure_state(structure: str, state: InitialState, ev: Event | EventData
                    ) -> InitialState:
    """``state`` ("rest" or "estimated", :func:`initial_state`) as a ``structure`` takes
    it: an integrating structure on a baseline that segmentation measured as a steady
    ramp (``drift``: a straight line before the first event, a previous window that ended
    on a steady ramp) starts "steady" (:func:`pipeline.refine.refine`), its balance point
    estimated. Estimating its state instead would let the lag's free response trade with
    the step response's own transient (the same exponential) on a short baseline, and the
    gain with the balance point."""
    if state == "estimated" and ev.drift and STRUCTURES[structure].integrating:
        return "steady"
    return state


#: How the intervals are made unless bootstrap refits were asked for.
JACOBIAN_INTERVALS = "Jacobian, scaled by the residuals' effective sample size"


def summary(ref: Refinement, carried_from: int | None = None) -> RefinementSummary:
    """What a fit carries of a refinement (:class:`pipeline.fit.RefinementSummary`): how
    the initial state was treated ("carried" when the span starts at rest at an earlier
    event, ``carried_from``, unless the structure starts "steady" there), the fitted
    operating point, the fit's own error and effective sample size, the standard errors."""
    state = "carried" if carried_from is not None and ref.initial_state != "steady" \
        else ref.initial_state
    return RefinementSummary(
        state=state, carried_from=carried_from if state == "carried" else None,
        y0=ref.y0, u0=ref.u0, mse_fit=ref.mse, n_fit=int(ref.residuals.size),
        n_eff=ref.n_eff, variance_factor=ref.variance_factor, n_params=ref.n_params,
        std=dict(ref.std), nfev=ref.nfev, runs=ref.n_runs,
        interval_method=ref.diagnostics.get("interval_method", JACOBIAN_INTERVALS),
        covariance=ref.covariance, sensitivity=ref.sensitivity)


def event_states(record: Record, events: Sequence[Event]) -> list[InitialState]:
    """:func:`initial_state` of every event of a record."""
    return [initial_state(EventData.from_event(record, ev), events[i - 1].settled if i else None)
            for i, ev in enumerate(events)]


def carry_source(states: Sequence[str], i: int) -> int | None:
    """The latest event ``j <= i`` that starts at rest (the state of event ``i`` can be
    carried from there), or None."""
    return next((j for j in range(i, -1, -1) if states[j] == "rest"), None)
