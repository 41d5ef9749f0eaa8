"""The running controller's settings, read off its own log (setpoint ``r``, measurement
``y``, controller output ``u``): issue 32 item 1, "identification of the running
controller's own settings from r, y, u".

The controller is taken as the positional ideal (ISA) PID with the derivative on the
measurement (no derivative kick), filtered by ``Tf = Td / N`` (Åström & Hägglund,
*Advanced PID Control*, ISA 2006, sec. 3.2-3.3), sampled at ``h``::

    u[k] = u_b + Kc (e[k] + I[k] + D[k]),    e = r - y
    I[k] = sum_{j<k} h e[j] / Ti                          (forward Euler)
    D[k] = Tf/(Tf + h) D[k-1] - Td/(Tf + h) (y[k] - y[k-1])  (backward Euler)

Given the filter's ``Tf`` the output is linear in ``(u_b, Kc, Kc/Ti, Kc Td)``: ordinary
least squares on the regressors ``1, e, sum h e, g`` with ``g`` the filtered derivative
of unit gain. ``Tf`` follows ``Td``, so the fit is iterated from the unfiltered
derivative until ``Td`` moves by less than 1e-9 of itself or of the sample time (a
fixed point: the filter is ten times faster than the derivative it smooths; a
controller whose filter is ``min(Td, Ti) / N``, as
:meth:`pipeline.tuning.controller.Controller.ideal` makes it, is read the same unless
``Ti < Td``; the controller returned carries the ``Tf = Td / N`` it was read with). The
kind is the simplest the log supports: the derivative and the
integral terms are kept where their coefficients are beyond :data:`Z_TERM` standard
errors. Standard errors are the least-squares ones scaled by
the residuals' long-run variance factor (:func:`pipeline.uncertainty.variance_factor`);
``Ti`` and ``Td`` are ratios, their standard errors by the delta method.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.signal import lfilter

from ..uncertainty import variance_factor
from .controller import DERIVATIVE_FILTER_N, Controller

#: A term is in the controller when its coefficient is beyond this many standard errors.
Z_TERM = 4.0
#: Fixed-point iterations of the derivative filter at most.
MAX_FILTER_ITERATIONS = 50


@dataclass(frozen=True)
class RunningController:
    """The settings read off a log: the controller (ideal form), the standard errors of
    ``Kc``, ``Ti``, ``Td`` (absent terms: none), the output bias ``u_b`` and the RMS of
    what the settings do not explain (quantisation, output limits, a different
    discretisation), relative to the controller output's standard deviation;
    ``converged``: whether the derivative filter's fixed point was reached within
    :data:`MAX_FILTER_ITERATIONS` (the settings are the last iterate's otherwise). The
    standard errors take the filter as known: ``Td``'s is somewhat too small where the
    filter matters."""

    controller: Controller
    std: dict[str, float]
    bias: float
    residual_share: float
    converged: bool = True


def _filtered_derivative(y: np.ndarray, h: float, tf: float) -> np.ndarray:
    """``g`` with ``D = Td g``: ``g[k] = Tf/(Tf + h) g[k-1] - (y[k] - y[k-1])/(Tf + h)``,
    ``g[0] = 0``."""
    dy = np.r_[0.0, np.diff(y)]
    return lfilter([-1.0 / (tf + h)], [1.0, -tf / (tf + h)], dy)


def _solve(cols: list[np.ndarray], u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(coefficients, their covariance, residuals)`` of ``u`` on ``cols``."""
    x = np.column_stack(cols)
    c, *_ = np.linalg.lstsq(x, u, rcond=None)
    e = u - x @ c
    dof = max(u.size - x.shape[1], 1)
    s2 = float(e @ e) / dof * variance_factor(e)
    return c, s2 * np.linalg.pinv(x.T @ x), e


def identify_controller(t, r, y, u, *, filter_n: float = DERIVATIVE_FILTER_N
                        ) -> RunningController:
    """The running controller of a log sampled at ``t`` (uniform) with setpoint ``r``,
    measurement ``y`` and controller output ``u`` (see the module docstring). Raises
    ValueError when the arrays differ in length, the sampling is not uniform, or the
    error never moves (no setpoint or load change: nothing to read the settings from)."""
    t, r, y, u = (np.asarray(a, np.float64) for a in (t, r, y, u))
    if not t.size == r.size == y.size == u.size or t.size < 20:
        raise ValueError("t, r, y and u must have the same length, at least 20 samples")
    steps = np.diff(t)
    h = float(np.median(steps))
    if not h > 0 or np.max(np.abs(steps - h)) > 0.01 * h:
        raise ValueError("the controller's log must be sampled uniformly (within 1 %)")
    e = r - y
    if not np.ptp(e) > 0:
        raise ValueError("the control error never changes: no setpoint step or load to "
                         "read the controller from")
    integral = np.r_[0.0, np.cumsum(h * e[:-1])]
    ones = np.ones(t.size)
    td, kept, converged = 0.0, None, False
    for _ in range(MAX_FILTER_ITERATIONS):
        g = _filtered_derivative(y, h, td / filter_n)
        c, cov, res = _solve([ones, e, integral, g], u)
        new = c[3] / c[1] if c[1] != 0 else 0.0
        kept = (c, cov, res, g)
        if not new > 0 or abs(new - td) <= 1e-9 * max(new, h):  # (a Td of 1e-9 sample
            # times is no derivative: a PI's rounding-level Kd converges there)
            converged = True
            break
        td = new
    c, cov, res, g = kept
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    has_d = c[3] != 0 and abs(c[3]) > Z_TERM * se[3] and c[3] / c[1] > 0
    cols = [ones, e, integral] + ([g] if has_d else [])
    c, cov, res = _solve(cols, u)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    has_i = c[2] != 0 and abs(c[2]) > Z_TERM * se[2] and c[2] / c[1] > 0
    if not has_i:
        cols = [ones, e] + ([g] if has_d else [])
        c, cov, res = _solve(cols, u)
        c = np.insert(c, 2, 0.0)
        cov = np.insert(np.insert(cov, 2, 0.0, axis=0), 2, 0.0, axis=1)
    kc = float(c[1])
    std = {"Kc": math.sqrt(max(cov[1, 1], 0.0))}
    ti = math.inf
    if has_i:
        ki = float(c[2])
        ti = kc / ki
        grad = np.array([1.0 / ki, -kc / ki**2])  # d(Kc/Ki) / d(Kc, Ki)
        std["Ti"] = math.sqrt(max(float(grad @ cov[1:3, 1:3] @ grad), 0.0))
    td = 0.0
    if has_d:
        kd = float(c[3])
        td = kd / kc
        idx = [1, 3]
        grad = np.array([-kd / kc**2, 1.0 / kc])  # d(Kd/Kc) / d(Kc, Kd)
        std["Td"] = math.sqrt(max(float(grad @ cov[np.ix_(idx, idx)] @ grad), 0.0))
    spread = float(np.std(u))
    share = float(np.sqrt(np.mean(res * res))) / spread if spread > 0 else 0.0
    # the filter the settings were read with (Td/N), also where Ti < Td (ideal() would
    # take min(Td, Ti)/N there): the loop these settings describe is the one fitted
    ctl = Controller.ideal(kc, ti, td, n=filter_n)
    ctl = replace(ctl, Tf=td / filter_n) if td > 0 else ctl
    return RunningController(ctl, std, float(c[0]), share, converged)
