"""Least-squares refinement: the output-error model of one structure fitted to the data as a
whole, with the operating point and the initial state estimated, and calibrated intervals.

The model driven by the measured input (exact zero-order hold, fractional dead time,
:mod:`pipeline.simulation.regressors`), in deviation variables from ``(u_ref, y0)``:

    y_hat(t) = y0 + K x(t; theta) + sum_j c_j b_j(t; theta) [+ c_u s(t; theta)]

is fitted by minimising the simulation (output) error over the chosen samples, the
output-error / prediction-error method with an output-error noise model (Ljung, System
Identification, 2nd ed., 1999, sec. 4.2 and 7.2). The gain ``K``, the offset ``y0``, the
free-response coefficients ``c_j`` (the initial state, when it is estimated), for an
integrating structure with an estimated state the input balance point (at rest the model
is in equilibrium at ``u_ref``), and ``K Tz`` (a zero, :data:`LINEAR_PARAMS`) enter
linearly, so they are solved by linear least squares inside the residual function:
separable least squares, or variable projection (G. H. Golub, V. Pereyra, "The
differentiation of pseudo-inverses and nonlinear least squares problems whose variables
separate", SIAM J. Numer. Anal. 10(2):413-432, 1973). The nonlinear search
(``scipy.optimize.least_squares``, trust-region reflective, bounded) only sees the lags,
damping, order and dead time, on log scale where a parameter is positive
(:mod:`pipeline.refine.search`). It runs from the best few of many
candidate starts (the graphical methods' models, and templates scaled to their time
scales, :func:`pipeline.refine.search.candidate_starts`) and keeps the best.
An order ``n`` is searched as a real number, then fixed at the better of the two integers
around it (a rational transfer function).

Intervals: the profiled Jacobian of (theta, K), with the offset and state columns projected
out (the Schur complement of the full Gauss-Newton matrix, which is how variable projection
gives the covariance of all parameters), times the residual variance and the coloured-noise
factor of :mod:`pipeline.uncertainty` (its effective sample size also sets the residual
variance's and the t quantile's degrees of freedom); on log scale for positive
parameters, so an interval never crosses zero. Optionally a moving-block bootstrap
instead.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import get_args

import numpy as np

from ..fit import InitialState, ParameterCovariance, RowSensitivity
from ..models import STRUCTURES, ProcessModel
from ..uncertainty import (
    block_bootstrap_residuals,
    covariance,
    gram_pinv,
    t_quantile,
    variance_factor,
)
from .coincident import (
    coincide,
    difference_variance,
    from_symmetric,
    lag_pair,
    symmetric_jacobian,
)
from .lstsq import block_means, project_out, solve
from .lstsq import runs as mask_runs
from .problem import Columns, Problem
from .search import Run, Space, multistart, search_space, snap

#: Parameters the response is affine in: a zero's time constant (the numerator
#: ``K (Tz s + 1)`` makes the response ``K x(Tz=0) + K Tz (x(Tz=1) - x(Tz=0))``). The search
#: solves them with the gain by linear least squares (variable projection), so it sees only
#: the lags and the dead time and no start has to guess a zero: from starts whose zero is
#: off the search fell into a pure-gain local minimum (a lead-lag with Tz ~ T).
LINEAR_PARAMS = ("Tz",)
#: Degrees of freedom of the interval quantile at least: fewer effective samples mean the
#: residuals are a systematic misfit, not noise (the standard error already grew by the
#: variance factor; grading reads ``n_eff`` to say so).
MIN_DOF = 10
#: Parameters fitted as integers (the order of an equal-lag chain, as Strejc's n).
INTEGER_PARAMS = ("n",)


@dataclass(frozen=True)
class RefineOptions:
    """``n_starts`` least-squares runs from the best candidate starts; ``max_nfev``
    residual evaluations per run; ``max_rows`` criterion rows at most (block means beyond;
    with ``coarse`` the search runs on a decimated copy first and the exact problem is
    polished from its optimum); ``free_lags`` columns at most for the free response;
    ``bootstrap`` block-bootstrap refits for the intervals (0: Jacobian intervals),
    ``seed`` their resampling; ``level`` of the intervals; ``sensitivity``: keep the
    profiled pseudo-inverse's rows (:class:`pipeline.fit.RowSensitivity`), for intervals
    widened by held-out residuals (:mod:`pipeline.refine.heldout_noise`)."""

    n_starts: int = 3
    max_nfev: int = 300
    max_rows: int = 600
    coarse: bool = True
    free_lags: int = 3
    bootstrap: int = 0
    seed: int = 0
    level: float = 0.95
    sensitivity: bool = False


@dataclass(frozen=True)
class Refinement:
    """A refined model: its parameters with intervals, the fitted operating point, the
    fit's residuals over the chosen samples and how it was obtained; ``fitted``, the
    model's output at those samples, only when bootstrap refits were asked for (they
    start from it; on a long span it is one more array of the span's length)."""

    model: ProcessModel
    y0: float
    u0: float
    ci95: dict[str, tuple[float, float]]
    std: dict[str, float]
    fitted: np.ndarray | None
    residuals: np.ndarray
    initial_state: InitialState
    n_linear: int
    variance_factor: float
    nfev: int
    n_runs: int
    diagnostics: dict = field(default_factory=dict)
    covariance: ParameterCovariance | None = None
    sensitivity: RowSensitivity | None = None

    @property
    def mse(self) -> float:
        return float(np.mean(self.residuals**2)) if self.residuals.size else math.nan

    @property
    def n_params(self) -> int:
        """Estimated parameters: the model's (K and the searched ones) plus the linear
        nuisances (offset, state, input balance point)."""
        return len(self.std) + self.n_linear - 1

    @property
    def n_eff(self) -> float:
        return self.residuals.size / self.variance_factor


def refine(t, u, y, structure: str, *, u_ref: float, starts: Sequence[Mapping[str, float]],
           mask: np.ndarray | None = None, initial_state: InitialState = "rest",
           fixed: Mapping[str, float] | None = None, options: RefineOptions | None = None
           ) -> Refinement:
    """Fit ``structure`` to ``y`` over the span ``t, u`` (the model starts at the first
    sample: at rest at ``u_ref`` when ``initial_state`` is "rest", with its state
    estimated when "estimated", and an integrating structure with "steady" on a steady
    ramp: its lags at equilibrium, the output moving at ``K (u_ref - u0)`` with the
    balance point ``u0`` estimated); ``mask`` selects the samples in the criterion (all by default);
    ``starts`` are parameter sets to start from (missing ones: :func:`pipeline.refine.search.
    defaults`), ``fixed`` parameters are held. Pure: numpy arrays in, a
    :class:`Refinement` out."""
    opt = options or RefineOptions()
    o = _optimum(t, u, y, structure, u_ref, starts, mask, initial_state, fixed, opt)
    ref = _finish(o.problem, o.space, o.params, y, initial_state, u_ref, opt, o.nfev, o.runs)
    if opt.bootstrap > 0:
        ref = _bootstrap(o.search, o.searched, ref, dict(fixed or {}), opt)
    return ref


def refine_model(t, u, y, structure: str, *, u_ref: float,
                 starts: Sequence[Mapping[str, float]], mask: np.ndarray | None = None,
                 initial_state: InitialState = "rest", fixed: Mapping[str, float] | None = None,
                 options: RefineOptions | None = None) -> tuple[ProcessModel, float]:
    """:func:`refine`'s model and input balance point ``u0`` alone, the same to the bit,
    without its intervals (the profiled Jacobian: ``2 x`` the searched parameters more
    simulations of the span) or its residuals: a cross-validation fold's refit is
    scored on the events it left out, its intervals never read."""
    opt = options or RefineOptions()
    o = _optimum(t, u, y, structure, u_ref, starts, mask, initial_state, fixed, opt)
    _, _, c, _, u0 = _linear_fit(o.problem, o.params, u_ref)
    return _model(o.problem.structure, o.params, float(c[0]), {}, {})[0], u0


@dataclass(frozen=True)
class _Optimum:
    """Where the search of :func:`refine` ended: the problem (``search``: with its
    :data:`LINEAR_PARAMS` solved inside the residual), the parameter space (``searched``:
    less those), the parameters, residual evaluations and starts tried."""

    problem: Problem
    search: Problem
    space: Space
    searched: Space
    params: dict[str, float]
    nfev: int
    runs: int


def _optimum(t, u, y, structure: str, u_ref: float, starts, mask, initial_state: InitialState,
             fixed, opt: RefineOptions) -> _Optimum:
    """The search of :func:`refine`, without the intervals: the parameters at the optimum
    (snapped to a bound within its tolerance, the linear ones from their solve); a long
    window coarse to fine (the optimum on a decimated copy, polished on the whole)."""
    if initial_state not in get_args(InitialState) or (
            initial_state == "steady" and not STRUCTURES[structure].integrating):
        raise ValueError(f"initial state {initial_state!r} for a {structure} model")
    t = np.asarray(t, dtype=np.float64)
    mask = np.ones(t.size, bool) if mask is None else np.asarray(mask, bool)
    y = np.asarray(y, np.float64)
    prob = Problem.of(t, u, y, structure, u_ref=u_ref, mask=mask, initial_state=initial_state,
                      free_lags=opt.free_lags, max_rows=opt.max_rows)
    dt, span = prob.dt, prob.horizon
    spec = STRUCTURES[structure]
    fixed = dict(fixed or {})
    names = [n for n in spec.params if n != "K" and n not in fixed]
    dt_eff = dt or float(np.median(np.diff(t)))
    space = search_space(structure, names, dt_eff, span)
    search = replace(prob, linear=tuple(n for n in names if n in LINEAR_PARAMS))
    searched = search_space(structure, [n for n in names if n not in search.linear], dt_eff,
                            span)
    ints = [n for n in names if n in INTEGER_PARAMS]
    m = math.ceil(t.size / opt.max_rows)
    if dt is not None and m > 2 and opt.coarse:
        # coarse to fine: the search on a decimated copy (its optimum only: the intervals
        # of the coarse fit would be thrown away), the exact problem polished from it
        c = _optimum(t[::m], block_means(np.asarray(u, np.float64), m), y[::m], structure,
                     u_ref, starts, mask[::m], initial_state, fixed,
                     replace(opt, bootstrap=0, coarse=False))
        # the order of exchangeable lags as the coarse fit's model has them (the gain
        # does not enter the comparison of the step responses)
        params = {n: 1.0 if n == "K" else float(c.params[n]) for n in spec.params}
        params = canonical(structure, params, {}, {})[0]
        start = {n: params[n] for n in names}
        if ints:
            best = _integer(search, searched, fixed, start, ints, dt_eff, span, opt,
                            polish=True)
        else:
            best = _multistart(search, searched, fixed, [start], 1, opt.max_nfev)
        nfev, runs = best.nfev + c.nfev, c.runs
    else:
        best = _multistart(search, searched, fixed, starts, opt.n_starts, opt.max_nfev)
        nfev, runs = best.nfev, best.runs
        if ints:
            best = _integer(search, searched, fixed, best.params, ints, dt_eff, span, opt)
            nfev += best.nfev
    p = {**fixed, **snap(space, {**best.params, **_linear_values(search, {**fixed,
                                                                          **best.params})})}
    return _Optimum(prob, search, space, searched, p, nfev, runs)


def _solution(prob: Problem, p: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """``(criterion rows of the design, linear coefficients)`` at ``p``."""
    a = prob.design_rows(p)
    return a, solve(a, prob.y)[0]


def _residual(prob: Problem, p: Mapping[str, float]) -> np.ndarray:
    a, c = _solution(prob, p)
    return prob.y - a @ c


def _linear_values(prob: Problem, p: Mapping[str, float]) -> dict[str, float]:
    """The :data:`LINEAR_PARAMS` of the linear solve at ``p``: coefficient over gain."""
    if not prob.linear:
        return {}
    _, c = _solution(prob, p)
    k = float(c[0]) or 1e-300
    return {n: float(c[1 + i]) / k for i, n in enumerate(prob.linear)}


def _multistart(prob: Problem, space: Space, fixed, starts, n_starts: int, max_nfev: int
                ) -> Run:
    """The best least-squares run (:func:`pipeline.refine.search.multistart`) of the residual
    over ``space`` with ``fixed`` held."""
    if not space.names:
        return Run({}, 0.5 * float(np.sum(_residual(prob, fixed) ** 2)), 1, 0)
    return multistart(lambda z: _residual(prob, {**fixed, **space.from_z(z)}), space, starts,
                      n_starts, max_nfev)


def _integer(prob: Problem, space: Space, fixed, p_best, ints, dt, span, opt,
             polish: bool = False) -> Run:
    """Refit with each integer parameter fixed at the integers around its real optimum
    (``polish``: at the value it has, an integer already)."""
    options = [[round(p_best[n])] if polish or abs(p_best[n] - round(p_best[n])) < 0.2 else
               [math.floor(p_best[n]), math.ceil(p_best[n])] for n in ints]
    sub = search_space(prob.structure, [n for n in space.names if n not in ints], dt, span)
    best, nfev = None, 0
    bounds = STRUCTURES[prob.structure].bounds
    for combo in itertools.product(*options):
        vals = {n: float(min(max(v, bounds[n][0]), bounds[n][1]))
                for n, v in zip(ints, combo, strict=True)}
        run = _multistart(prob, sub, {**fixed, **vals}, [p_best], 1, opt.max_nfev)
        nfev += run.nfev
        if best is None or run.cost < best.cost:
            best = Run({**run.params, **vals}, run.cost, 0, 0)
    return replace(best, nfev=nfev)


def _finish(prob: Problem, space: Space, p: Mapping[str, float], y: np.ndarray,
            initial_state: InitialState, u_ref: float, opt: RefineOptions, nfev: int, runs: int
            ) -> Refinement:
    """Linear coefficients, the profiled Jacobian and the intervals at ``p`` (``y``: the
    span's output). Of the span-long arrays only the residuals are alive while the
    Jacobian simulates the span: the design's columns are dropped before it, and the
    fitted output too unless bootstrap refits start from it."""
    cols, rows, c, rank, u0 = _linear_fit(prob, p, u_ref)
    rows_resid = prob.y - rows @ c
    fitted = cols.product(c, None if prob.full else prob.mask)
    del cols, rows
    resid = np.asarray(y, np.float64)[prob.mask]  # a copy, made the residuals in place
    np.subtract(resid, fitted, out=resid)
    if opt.bootstrap <= 0:
        fitted = None
    K, y0 = float(c[0]), float(c[1])
    free = list(space.names)
    jac = _profiled_jacobian(prob, space, p, K)
    factor = variance_factor(rows_resid)
    cov = covariance(jac, rows_resid, rank + len(free), factor)
    q = t_quantile(max(rows_resid.size / factor - rank - len(free), MIN_DOF), opt.level)
    z = space.to_z(p) if free else np.empty(0)
    pair, coincident = lag_pair(space), False
    if pair is not None and coincide(pair, z, cov, q):
        # two lags the data cannot tell apart: their split bounded by the data in the
        # coordinates the response is smooth in, where that is the narrower bound (far
        # from coincidence the plain linearisation holds; pipeline.refine.coincident)
        sym = symmetric_jacobian(_profile(prob, space, p, K), jac, z, pair)
        c_sym = from_symmetric(covariance(sym, rows_resid, rank + len(free), factor), z,
                               pair, q)
        if difference_variance(pair, c_sym) < difference_variance(pair, cov):
            cov, jac, coincident = c_sym, sym, True
    model = _model(prob.structure, p, K, {}, {})[0]
    names = free + ["K"]
    if "T1" in names and "T2" in names and model.params["T1"] != p["T1"]:  # swapped
        names = [{"T1": "T2", "T2": "T1"}.get(n, n) for n in names]
    cov_z = ParameterCovariance(
        tuple(names), (*map(bool, space.log), False), (*map(float, space.scale), 1.0),
        (*map(float, z), K), tuple(tuple(map(float, row)) for row in cov))
    ci, std = intervals(prob.structure, cov_z, model.params, q)
    sens = None
    if opt.sensitivity and (prob.mask is None or mask_runs(prob.mask)[0].size == 1):
        # the rows consecutive in time (one run of fit samples)
        sens = RowSensitivity(gram_pinv(jac) @ jac.T, int(np.median(prob.counts))
                              if prob.counts.size else 1, q, pair if coincident else None)
    return Refinement(
        model=model, y0=y0, u0=float(u0), ci95=ci, std=std, fitted=fitted, residuals=resid,
        initial_state=initial_state, n_linear=rank, variance_factor=variance_factor(resid),
        nfev=nfev, n_runs=runs, diagnostics={"coefficients": [float(v) for v in c[2:]],
                                             "rows": int(prob.y.size), "quantile": q,
                                             "coincident_lags": coincident},
        covariance=cov_z,
        sensitivity=sens)


def intervals(structure: str, cov: ParameterCovariance, values: Mapping[str, float],
              q: float) -> tuple[dict[str, tuple[float, float]], dict[str, float]]:
    """``(intervals, standard errors)`` of each coordinate of ``cov`` at ``q`` standard
    deviations: on log scale (never crossing zero) for a log coordinate, the standard
    error its delta-method value ``sd x value`` (``values``: the parameters at the fit);
    a linear one times its scale within the structure's bounds; the gain unbounded."""
    sd = np.sqrt(np.maximum(np.diag(np.asarray(cov.matrix, np.float64)), 0.0))
    ci: dict[str, tuple[float, float]] = {}
    std: dict[str, float] = {}
    spec = STRUCTURES[structure]
    bounds = spec.bounds
    at = {n: i for i, n in enumerate(cov.names)}
    for n in ["K", *(n for n in spec.params if n != "K" and n in at)]:  # the gain first
        i = at[n]
        zi, s = cov.z[i], float(sd[i])
        lo, hi = zi - q * s, zi + q * s
        if n == "K":
            ci[n], std[n] = (lo, hi), s
        elif cov.log[i]:
            ci[n] = (math.exp(max(lo, -700.0)), math.exp(min(hi, 700.0)))
            std[n] = s * float(values[n])
        else:
            b_lo, b_hi = bounds.get(n, (-math.inf, math.inf))
            ci[n] = (max(float(lo * cov.scale[i]), b_lo), min(float(hi * cov.scale[i]), b_hi))
            std[n] = s * cov.scale[i]
    return ci, std


def _linear_fit(prob: Problem, p, u_ref: float
                ) -> tuple[Columns, np.ndarray, np.ndarray, int, float]:
    """``(span design's columns, its criterion rows, linear coefficients, their rank, input
    balance point)`` at ``p`` (the balance point ``u_ref`` unless an integrating
    structure's is estimated)."""
    a = prob.columns(p)
    rows = prob.reduce(a)
    c, rank = solve(rows, prob.y)
    u0 = u_ref
    if prob.balance and float(c[0]) != 0:
        u0 = u_ref - float(c[2]) / float(c[0])
    return a, rows, c, rank, float(u0)


def _model(structure: str, p, K: float, ci, std) -> tuple[ProcessModel, dict, dict]:
    """The model of gain ``K`` and parameters ``p``, its exchangeable lags in canonical
    order (:func:`canonical`, the intervals swapped with them)."""
    params = {n: K if n == "K" else float(p[n]) for n in STRUCTURES[structure].params}
    params, ci, std = canonical(structure, params, ci, std)
    return ProcessModel(structure, params), ci, std


def _profile(prob: Problem, space: Space, p, K: float):
    """``P(theta) (y - K x(theta))`` as a function of the search coordinates ``z``, with
    ``x(theta)``'s rows and the projection's basis: the nuisance columns (offset, state,
    input balance) projected out by ``P``. ``prob`` is the fit's problem, not its
    search's: no parameter is solved linearly in it (its forced column is the response
    at ``p``, not at the linear ones' zero)."""
    assert not prob.linear, "the profiled Jacobian of a problem with linear parameters"

    def prof(z):
        q = {**p, **space.from_z(z)}
        rows = prob.design_rows(q)  # the forced column's rows, then the nuisance's
        qb = project_out(np.ascontiguousarray(rows[:, 1:]))
        xr = np.ascontiguousarray(rows[:, 0])
        del rows
        r = prob.y - K * xr
        return r - qb @ (qb.T @ r), xr, qb

    return prof


def _profiled_jacobian(prob: Problem, space: Space, p, K: float) -> np.ndarray:
    """Jacobian of :func:`_profile`'s residual wrt (z, K); central differences in z."""
    prof = _profile(prob, space, p, K)
    z0 = space.to_z(p) if space.names else np.empty(0)
    _, x0, q0 = prof(z0)
    cols = []
    for i in range(z0.size):
        h = 1e-5 * max(1.0, abs(z0[i]))
        up, dn = min(z0[i] + h, space.hi[i]), max(z0[i] - h, space.lo_z[i])
        zu, zd = z0.copy(), z0.copy()
        zu[i], zd[i] = up, dn
        cols.append((prof(zu)[0] - prof(zd)[0]) / max(up - dn, 1e-300))
    cols.append(-(x0 - q0 @ (q0.T @ x0)))
    return np.column_stack(cols)


def canonical(structure, params, ci, std):
    """Order exchangeable time constants (e.g. two lags) so that T1 >= T2: detected by
    swapping them and comparing the step responses, for any structure."""
    if not {"T1", "T2"} <= set(params) or params["T1"] >= params["T2"]:
        return params, ci, std
    spec = STRUCTURES[structure]
    swap = {**params, "T1": params["T2"], "T2": params["T1"]}
    tt = np.linspace(0.05, 5.0, 25) * spec.time_scale(params)
    if np.allclose(spec.step(params, tt), spec.step(swap, tt), rtol=1e-9, atol=1e-12):
        for d in (ci, std):
            if "T1" in d and "T2" in d:
                d["T1"], d["T2"] = d["T2"], d["T1"]
        return swap, ci, std
    return params, ci, std


def _bootstrap(prob: Problem, space: Space, ref: Refinement, fixed, opt) -> Refinement:
    """Percentile intervals from refits to ``fitted + block-resampled residuals``."""
    draws = []
    start = {n: ref.model.params[n] for n in space.names}
    y_span = np.zeros(prob.mask.size)
    for e in block_bootstrap_residuals(ref.residuals, opt.bootstrap, opt.seed):
        y_span[prob.mask] = ref.fitted + e
        b = replace(prob, y=prob.rows(y_span))
        p = _multistart(b, space, fixed, [start], 1, opt.max_nfev).params
        p = {**p, **_linear_values(b, {**fixed, **p})}
        draw = {**ref.model.params, **p, "K": float(_solution(b, {**fixed, **p})[1][0])}
        draws.append(canonical(prob.structure, draw, {}, {})[0])
    a = (1 - opt.level) / 2
    ci = {n: (float(np.quantile([d[n] for d in draws], a)),
              float(np.quantile([d[n] for d in draws], 1 - a))) for n in ref.ci95}
    diag = {**ref.diagnostics, "interval_method": f"block bootstrap ({opt.bootstrap} refits)"}
    return Refinement(**{**ref.__dict__, "ci95": ci, "diagnostics": diag})
