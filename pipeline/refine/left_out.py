"""Refits with some samples left out, from the fit to all of them: Gauss-Newton steps on
the left-out problem, started at the full fit's optimum (cross-validation folds,
:func:`pipeline.refine.joint.cross_validate`).

Leaving a fold of events out moves the optimum of the output-error criterion
(:mod:`pipeline.refine`) by little: the fold is a tenth of the data or less. From the full
optimum ``z0`` Gauss-Newton steps on the fold's separable residual ``r_f(z)`` (the linear
parameters projected out by their least-squares solve, as in the search),

    z_{k+1} = z_k - (J_f^T J_f)^-1 J_f^T r_f(z_k),

converge fast from so close a start (quadratically on a small-residual problem: J.
Nocedal, S. J. Wright, Numerical Optimization, 2nd ed., 2006, sec. 10.3). The first step
alone is the one-step approximation of a leave-out refit (A. Beirami, M. Razaviyayn,
S. Shahrampour, V. Tarokh, "On optimal generalizability in parametric learning", NIPS
2017; K. R. Rad, A. Maleki, "A scalable estimate of the out-of-sample prediction error
via approximate leave-one-out cross-validation", J. R. Stat. Soc. B 82(4), 2020); here
the steps go on until the search's own stopping rule holds (:func:`_steps`), so the fold
model is the refit's to its tolerance, not an approximation of it, as long as the fold's
optimum lies in the full fit's basin; an integer order is held at the full fit's (an
exact refit would choose it again on the fold). A fold whose steps do not converge within
:data:`MAX_STEPS` returns None and the caller refits it exactly.

The cost is what makes it worth having: the simulated columns at ``z0`` and its
finite-difference neighbours do not depend on which samples are in the criterion, so the
first step of every fold shares ``2 p + 1`` simulations of the span (``p`` searched
parameters), where an exact refit of each fold takes about a hundred.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import replace

import numpy as np

from ..fit import InitialState
from ..models import STRUCTURES
from .lstsq import solve
from .problem import Problem
from .refinement import INTEGER_PARAMS, LINEAR_PARAMS, canonical
from .search import FTOL, Space, search_space

#: Gauss-Newton steps at most before the fold is handed back for an exact refit, and
#: tries of a step that raised the cost (the step, then halved each time).
MAX_STEPS, MAX_HALVINGS = 8, 4
#: A direction of the parameters whose standard error exceeds this (in search
#: coordinates: a factor e for one on log scale) is not determined by the data, and the
#: steps do not follow it (:func:`_bounded_step`).
UNDETERMINED = 1.0
#: A singular value below this fraction of the residual's standard deviation (a standard
#: error of a million in search coordinates; the finite differences' rounding is about
#: 1e-7 of it) is a direction the residual does not move along at all (a lead-lag's
#: fractional dead time within a sample, absorbed by its zero): neither stepped along nor
#: counted as undetermined. Relative to the largest singular value it misjudged: the dead
#: time's is 1e7 times the noise, and a second-order model's damping at 2e-9 of it still
#: held 0.4 % of the fold's cost.
NULL = 1e-6
#: Central-difference step in search coordinates on log scale (as
#: :mod:`pipeline.refine`'s profiled Jacobian), and for the dead time in sample times.
DIFF_STEP, DELAY_STEP = 1e-5, 1e-3


def left_out_fits(t, u, y, structure: str, *, u_ref: float, masks: Iterable[np.ndarray],
                  initial_state: InitialState, params: Mapping[str, float], free_lags: int = 3,
                  max_rows: int = 600) -> list[tuple[dict[str, float], float] | None]:
    """For each of ``masks`` (the criterion samples of the span ``t, u, y``), the model
    of ``structure`` fitted on them by Gauss-Newton steps from ``params`` (the fit on
    all the samples, with the same span, ``u_ref`` and ``initial_state`` as
    :func:`pipeline.refine.refine`): ``(parameters, input balance point)``, or None where
    the steps did not converge (refit that fold exactly). Integer parameters (an order)
    are held at their values in ``params``. Pure: numpy arrays in. ``masks`` is iterated
    once, and a fold keeps its criterion's rows, not its mask: a generator of them holds
    one span-long mask at a time."""
    spec = STRUCTURES[structure]
    held = {n: float(params[n]) for n in spec.params if n in INTEGER_PARAMS}
    base = Problem.of(t, u, y, structure, u_ref=u_ref, mask=np.ones(np.size(t), bool),
                      initial_state=initial_state, free_lags=free_lags, max_rows=max_rows)
    names = [n for n in spec.params if n != "K" and n not in held]
    base = replace(base, linear=tuple(n for n in names if n in LINEAR_PARAMS))
    dt = base.dt or float(np.median(np.diff(t)))
    space = search_space(structure, [n for n in names if n not in base.linear], dt,
                         base.horizon)
    folds = [base.with_mask(m, y, max_rows, keep_mask=False) for m in masks]
    z0 = space.to_z(params)
    # the first step's Jacobian: the span's columns at z0 and its neighbours, once; each
    # fold keeps its residual at z0 and, once a pair of neighbours is done, their
    # difference column (:func:`_jacobian`'s), not every neighbour's residual
    points = _neighbours(space, z0, dt)
    kept: list[list[np.ndarray] | None] = [[] for _ in folds]
    for j, z in enumerate(points):
        rows = base.rows_of({**held, **space.from_z(z)}, folds)  # a span column at a time
        for k, f in enumerate(folds):
            r = None if kept[k] is None else _guarded(_residual, f, rows[k])
            if r is None:
                kept[k] = None
            elif j and j % 2 == 0:  # the pair (z0 +- h e_i) of coordinate i = j/2 - 1
                i = j // 2 - 1
                up = kept[k].pop()
                kept[k].append((up - r) / max(points[j - 1][i] - z[i], 1e-300))
            else:
                kept[k].append(r)
        del rows
    out = []
    for f, r in zip(folds, kept, strict=True):
        z = None if r is None else _guarded(_steps, f, space, held, z0, r[0],
                                            _stack(r[1:], r[0].size), dt)
        out.append(None if z is None else _guarded(_model, f, space, held, z, u_ref))
    return out


def _guarded(fn, *args):
    """``fn(*args)``, or None where the linear algebra fails (a non-finite design far out
    in a bound's corner): the caller refits that fold exactly instead of losing the joint
    fit."""
    try:
        return fn(*args)
    except (np.linalg.LinAlgError, ValueError, FloatingPointError):
        return None


def _neighbours(space: Space, z0: np.ndarray, dt: float) -> list[np.ndarray]:
    """``z0``, then ``z0 +- h e_i`` inside the bounds (the central differences):
    :data:`DIFF_STEP` on log scale, a thousandth of the sample time ``dt`` for the dead
    time (in search coordinates its unit is the span, and a step of a hundred-thousandth
    of a long span is samples, across which the fractional-delay response bends)."""
    out = [z0]
    for i in range(z0.size):
        h = (DIFF_STEP * max(1.0, abs(z0[i])) if space.log[i] else
             DELAY_STEP * dt / space.scale[i])
        for v in (min(z0[i] + h, space.hi[i]), max(z0[i] - h, space.lo_z[i])):
            z = z0.copy()
            z[i] = v
            out.append(z)
    return out


def _residual(f: Problem, a: np.ndarray) -> np.ndarray:
    """The separable residual of fold ``f`` with design rows ``a``."""
    return f.y - a @ solve(a, f.y)[0]


def _jacobian(points: list[np.ndarray], r: list[np.ndarray]) -> np.ndarray:
    """Central differences of the residuals ``r`` at :func:`_neighbours`' ``points``."""
    cols = []
    for i in range(len(points) // 2):
        up, dn = points[1 + 2 * i], points[2 + 2 * i]
        cols.append((r[1 + 2 * i] - r[2 + 2 * i]) / max(up[i] - dn[i], 1e-300))
    return _stack(cols, r[0].size)


def _stack(cols: list[np.ndarray], rows: int) -> np.ndarray:
    """The Jacobian of the difference columns ``cols`` (``rows`` x 0 without any)."""
    return np.column_stack(cols) if cols else np.zeros((rows, 0))


def _steps(f: Problem, space: Space, held, z0: np.ndarray, r0: np.ndarray,
           jac0: np.ndarray, dt: float) -> np.ndarray | None:
    """Gauss-Newton steps on fold ``f`` from ``z0`` (``r0``, ``jac0``: the residual and
    its Jacobian there), None if they do not converge (see the module). They stop, as
    the least-squares search does (:data:`pipeline.refine.search.FTOL`), when the cost the
    linearised problem could still gain, or a step gained, is below ``FTOL`` of it (a
    small step is not enough: with coloured noise the steps shrink slowly); a step that
    raises the cost is halved, and when it and :data:`MAX_HALVINGS` - 1 halvings still do
    not gain, the last of which moved the cost by less than ``FTOL`` of it, the point is
    as converged as the search would leave it (its trust region shrinks the same way,
    ``scipy.optimize.least_squares``' xtol)."""
    z, r0, jac = z0, r0, jac0
    for it in range(MAX_STEPS):
        step = _bounded_step(space, z, jac, r0)
        if step is None:
            return None
        cost = float(r0 @ r0)
        lin = r0 + jac @ step
        if not step.any() or cost - float(lin @ lin) <= FTOL * cost:
            return z
        for _ in range(MAX_HALVINGS):
            z_new = np.clip(z + step, space.lo_z, space.hi)
            r_new = _residual(f, f.design_rows({**held, **space.from_z(z_new)}))
            cost_new = float(r_new @ r_new)
            if math.isfinite(cost_new) and cost_new < cost:
                break
            step = step / 2
        else:  # no halving gained: converged if the last one moved the cost by < FTOL
            return z if abs(cost_new - cost) <= FTOL * cost else None
        if cost - cost_new <= FTOL * cost:
            return z_new
        if it == MAX_STEPS - 1:
            return None
        z = z_new
        r = [r_new] + [_residual(f, f.design_rows({**held, **space.from_z(p)}))
                       for p in _neighbours(space, z, dt)[1:]]
        r0, jac = r_new, _jacobian(_neighbours(space, z, dt), r)
        del r
    return None


def _bounded_step(space: Space, z: np.ndarray, jac: np.ndarray, r: np.ndarray
                  ) -> np.ndarray | None:
    """The Gauss-Newton step, with the coordinates at a bound that it would push out of
    held there (the step of the others re-solved); None when the data leave a direction
    undetermined that could still gain more than ``FTOL`` of the cost. A direction (a
    right singular vector of the Jacobian) is undetermined when its standard error,
    ``sigma / s_k`` with ``sigma`` the residual's, exceeds :data:`UNDETERMINED` in search
    coordinates (a second lag far below the sample time): the step along it leaves the
    region the linear model describes (the cost rose a thousandfold), and only the
    search's trust region follows such a valley, so that fold is refitted exactly."""
    sigma = math.sqrt(float(r @ r) / max(r.size - z.size, 1))
    free = np.ones(z.size, bool)
    for _ in range(z.size + 1):
        step = np.zeros(z.size)
        if free.any():
            u, s, vt = np.linalg.svd(jac[:, free], full_matrices=False)
            null = s <= NULL * sigma  # the residual does not move along it
            keep = ~null & (s * UNDETERMINED > sigma)
            gain = u[:, ~keep & ~null].T @ r
            if gain @ gain > FTOL * float(r @ r):
                return None
            step[free] = -vt[keep].T @ ((u[:, keep].T @ r) / s[keep])
        tol = 1e-6 * (space.hi - space.lo)
        out = ((z <= space.lo_z + tol) & (step < 0)) | ((z >= space.hi - tol) & (step > 0))
        if not (out & free).any():
            return np.clip(z + step, space.lo_z, space.hi) - z
        free &= ~out
    return np.zeros(z.size)


def _model(f: Problem, space: Space, held, z: np.ndarray, u_ref: float
           ) -> tuple[dict[str, float], float]:
    """The fold's parameters at ``z`` (gain and linear ones from the solve) and the input
    balance point."""
    p = {**held, **space.from_z(z)}
    c = solve(f.design_rows(p), f.y)[0]
    k = float(c[0])
    lin = {n: float(c[1 + i]) / (k or 1e-300) for i, n in enumerate(f.linear)}
    p = {**p, **lin}  # not snapped to a bound: a long span's snapping distance is samples
    u0 = u_ref - float(c[1 + len(f.linear) + 1]) / k if f.balance and k != 0 else u_ref
    params = {n: k if n == "K" else float(p[n]) for n in STRUCTURES[f.structure].params}
    return canonical(f.structure, params, {}, {})[0], (u0 if math.isfinite(u0) else u_ref)
