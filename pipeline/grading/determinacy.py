"""How well the data determine a model's response, beyond each parameter's own interval.

A parameter may be undetermined (a wide 95 % interval) while the step response is not: a
zero and a lag that trade against each other, a lag far below the response's time scale.
What matters for the model's use is the response:

* :func:`response_band` - the 95 % band of the step response that a refinement's
  parameter covariance gives (:class:`pipeline.fit.ParameterCovariance`: correlations
  included), from parameter sets drawn from it;
* :func:`response_change` - for a reading without a covariance: the step response's
  largest change when one parameter moves to an end of its interval, the others held;
* :func:`heldout_spread` - how far the parameters' uncertainty alone moves a
  refinement's simulation of the events it did not see (what a held-out misfit is judged
  against beside the noise).

The first two are relative to the response's largest magnitude over the window; grading's
``wide_ci`` compares them with :data:`pipeline.grading.verdicts.MATERIAL`. The third is in
the output's units.
"""

from __future__ import annotations

import math

import numpy as np

from ..events import Event
from ..fit import Fit
from ..models import ProcessModel
from ..record import Record
from ..validate import heldout_residuals

#: Parameter sets drawn from a refinement's covariance for its response band.
BAND_DRAWS = 200


def response_band(fit: Fit, horizon: float) -> float | None:
    """The 95 % band of the model's step response over ``[0, horizon]`` that the
    refinement's parameter covariance gives (:class:`pipeline.fit.ParameterCovariance`,
    :data:`BAND_DRAWS` draws, each clipped to the structure's bounds): its largest
    half-width relative to the response's largest magnitude. Correlated parameters (a
    zero and a lag that trade against each other) leave the response determined where
    each alone is not. None without a covariance (a graphical reading)."""
    cov = fit.refinement.covariance if fit.is_refined else None
    if cov is None:
        return None
    if not np.all(np.isfinite(cov.matrix)) or not np.all(np.isfinite(cov.z)):
        return math.inf  # no finite covariance: nothing is determined
    model = fit.model
    t = np.linspace(0.0, max(horizon, 1e-12), 101)
    s0 = model.unit_step(t)
    scale = float(np.max(np.abs(s0)))
    if scale == 0:
        return math.inf
    curves = []
    with np.errstate(all="ignore"):
        for draw in cov.draws(BAND_DRAWS):
            p = clamped(model, draw)
            try:
                curves.append(ProcessModel(model.structure, p).unit_step(t))
            except (ValueError, ZeroDivisionError, FloatingPointError, OverflowError):
                return math.inf
        a = np.array(curves)
        # the same quantiles: numpy's nanquantile takes 20x plain quantile's time on
        # (200, 101) curves (a loop over columns): 4 % of `--events all` on a 100 k-sample,
        # 20-event log
        lo, hi = (np.quantile(a, [0.025, 0.975], axis=0) if not np.isnan(a).any() else
                  np.nanquantile(a, [0.025, 0.975], axis=0))
    half = float(np.max((hi - lo) / 2.0)) / scale
    return half if math.isfinite(half) else math.inf


def clamped(model: ProcessModel, values: dict[str, float]) -> dict[str, float]:
    """``model``'s parameters with ``values`` put in, each clipped to the structure's
    bounds (a draw from a covariance may leave them)."""
    bounds = model.spec.bounds
    return {**model.params, **{k: min(max(v, bounds.get(k, (-math.inf, math.inf))[0]),
                                      bounds.get(k, (-math.inf, math.inf))[1])
                               for k, v in values.items()}}


def response_change(fit: Fit, name: str, horizon: float) -> float:
    """The largest change of the model's step response over ``[0, horizon]`` (relative to
    the response's largest magnitude) when ``name`` moves to either end of its 95 %
    interval, the other parameters held (inf for an interval without ends, or an end
    outside the structure's domain)."""
    model = fit.model
    lo, hi = fit.ci95[name]
    t = np.linspace(0.0, max(horizon, 1e-12), 201)
    s0 = model.unit_step(t)
    scale = float(np.max(np.abs(s0)))
    if scale == 0 or lo is None or hi is None:
        return math.inf
    b_lo, b_hi = model.spec.bounds.get(name, (-math.inf, math.inf))
    worst = 0.0
    for end in (float(lo), float(hi)):
        end = min(max(end, b_lo), b_hi)
        if not math.isfinite(end) or abs(end) > 1e100:
            return math.inf
        try:
            with np.errstate(all="ignore"):  # a lag at its bound 0: a jump, not a warning
                s = ProcessModel(model.structure, {**model.params, name: end}).unit_step(t)
                d = float(np.max(np.abs(s - s0))) / scale
        except (ValueError, ZeroDivisionError, FloatingPointError, OverflowError):
            return math.inf
        if not math.isfinite(d):
            return math.inf
        worst = max(worst, d)
    return worst


def heldout_spread(fit: Fit, record: Record, events: list[Event], heldout: list[int]
                   ) -> float | None:
    """The RMS, over the held-out samples, of the standard deviation that the refinement's
    parameter covariance gives its simulation of the events ``heldout`` (simulated as
    validation: :func:`pipeline.validate.heldout_residuals`, each run's offset from its
    warm-up). Linearised: one simulation per principal direction of the covariance, moved
    one standard deviation along it, the squared changes summed (the prediction variance
    ``diag(J C J^T)`` by finite differences; Ljung, System Identification, 2nd ed., eq.
    9.57). An integrating model's gain error grows along a validation run; a lag's error
    shows where the held-out steps are. None without a covariance (a reading). The fit's
    own covariance where the held-out residuals widened its intervals
    (:mod:`pipeline.refine.heldout_noise`): a misfit must not widen the spread it is
    judged against."""
    cov = None if not fit.is_refined else (fit.refinement.covariance_fit
                                           or fit.refinement.covariance)
    if cov is None or not heldout:
        return None
    matrix = np.asarray(cov.matrix, dtype=np.float64)
    z0 = np.asarray(cov.z, dtype=np.float64)
    if not (np.all(np.isfinite(matrix)) and np.all(np.isfinite(z0))):
        return math.inf
    model, balance = fit.model, fit.balance_point
    _, base = heldout_residuals(model, record, events, heldout, balance)
    if base.size == 0:
        return None
    w, vecs = np.linalg.eigh((matrix + matrix.T) / 2.0)
    total = np.zeros(base.size)
    with np.errstate(all="ignore"):
        for k in np.flatnonzero(w > 0):
            p = clamped(model, cov.at(z0 + math.sqrt(float(w[k])) * vecs[:, k]))
            try:
                _, e = heldout_residuals(ProcessModel(model.structure, p), record, events,
                                         heldout, balance)
            except (ValueError, ZeroDivisionError, FloatingPointError, OverflowError):
                return math.inf
            total += (e - base) ** 2
    spread = math.sqrt(float(np.mean(total)))
    return spread if math.isfinite(spread) else math.inf
