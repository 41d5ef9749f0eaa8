"""Refinement of one event (the ``lsq_<structure>`` methods run on an event alone), and
the decision how its initial state is treated.

* :func:`refine_event` - one event's window (the baseline before ``t0`` and the window
  after it), started from the graphical methods' models;
* :func:`initial_state` - "rest" when the baseline before the step is settled, else
  "estimated": the output is still moving there (the previous event did not settle, or
  the baseline drifts by more than its noise).

Estimating the state always would make the gain unidentifiable for a step at the first
samples of a window: after the dead time a first-order lag's step response and its free
response are the same exponential, and only the few samples before the step tell them
apart. So it is estimated only where the data say the plant was moving (MATLAB procest's
``InitialCondition`` choice, made from the data), and where the record holds an earlier
event that started at rest, :mod:`pipeline.joint` carries the state from there instead
(the measured input since then drives it, and the same gain explains the tail).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .events import Event, EventData
from .models import ProcessModel
from .record import Record
from .refine import Refinement, RefineOptions, refine
from .search import candidate_starts
from .uncertainty import variance_factor
from .validate import fit_start

#: A baseline drift larger than this share of the step's output change counts as moving
#: (when it is also beyond 3 standard errors of the noise).
DRIFT_FRACTION = 0.01


def baseline_moving(t: np.ndarray, y: np.ndarray, noise: float, dy: float) -> bool:
    """Whether the output drifts over the baseline ``t, y``: the straight-line change over
    it exceeds three standard errors and ``DRIFT_FRACTION`` of ``dy``. The standard error
    is the line's, from the scatter about it (at least ``noise``) and its colour (slow
    noise wanders like a drift: a white-noise error bar would call it one)."""
    if y.size < 4:
        return False
    tc = t - t[0]
    slope, icpt = np.polyfit(tc, y, 1)
    resid = y - (icpt + slope * tc)
    scatter = max(float(np.std(resid, ddof=2)) if y.size > 2 else 0.0, noise)
    se = scatter * math.sqrt(variance_factor(resid) / max(float(np.sum((tc - tc.mean())**2)),
                                                          1e-300))
    drift = abs(float(slope) * float(tc[-1]))
    return drift > max(3 * se * float(tc[-1]), DRIFT_FRACTION * abs(dy))


def initial_state(ev: EventData, previous_settled: bool | None = None) -> str:
    """"rest" or "estimated" for an event (see the module docstring)."""
    i0 = ev.i0
    if previous_settled is False:
        return "estimated"
    if i0 < 4:
        return "rest"  # nothing before the step to judge by: assumed (e.g. a record start)
    moving = baseline_moving(ev.t[:i0], ev.y[:i0], ev.noise, ev.dy)
    return "estimated" if moving else "rest"


def refine_event(ev: EventData, structure: str, *, models: Sequence[ProcessModel] | None = None,
                 state: str | None = None, options: RefineOptions | None = None
                 ) -> Refinement:
    """Refine ``structure`` on one event: its baseline (:func:`pipeline.validate.fit_start`)
    and window, the model at rest at the event's input level ``u0`` or with its initial
    state estimated (``state``; None: decided by :func:`initial_state`), started from
    ``models`` (the graphical methods' readings; :mod:`pipeline.methods.lsq` passes them)."""
    models = [] if models is None else list(models)
    sl = slice(fit_start(0, ev.i0, ev.t.size), ev.t.size)
    span = float(ev.t[-1] - ev.t[sl.start])
    return refine(ev.t[sl], ev.u[sl], ev.y[sl], structure, u_ref=ev.u0,
                  starts=candidate_starts(structure, models, span),
                  initial_state=state or initial_state(ev), options=options)


def result_parts(ref: Refinement, **extra) -> tuple[ProcessModel, dict, dict]:
    """``(model, diagnostics, ci95)`` of a refinement, as a fit carries them: the fitted
    operating point, how the initial state was treated, the fit's own error and effective
    sample size, and the standard errors."""
    diag = {
        "initial_state": ref.initial_state, "y0": ref.y0, "u0": ref.u0,
        "mse_fit": ref.mse, "n_fit": int(ref.residuals.size), "n_eff": ref.n_eff,
        "variance_factor": ref.variance_factor, "n_params": ref.n_params,
        "std": dict(ref.std), "nfev": ref.nfev, "runs": ref.n_runs,
        "interval_method": ref.diagnostics.get(
            "interval_method", "Jacobian, scaled by the residuals' effective sample size"),
        **extra,
    }
    return ref.model, diag, dict(ref.ci95)


def event_states(record: Record, events: Sequence[Event]) -> list[str]:
    """:func:`initial_state` of every event of a record."""
    return [initial_state(EventData.from_event(record, ev), events[i - 1].settled if i else None)
            for i, ev in enumerate(events)]


def carry_source(states: Sequence[str], i: int) -> int | None:
    """The latest event ``j <= i`` that starts at rest (the state of event ``i`` can be
    carried from there), or None."""
    return next((j for j in range(i, -1, -1) if states[j] == "rest"), None)
