"""Intervals of two exchangeable lags that the data cannot tell apart (issue 27 items 1, 8).

A two-lag response depends on the lags ``T1``, ``T2`` symmetrically, so on their log
difference ``d = ln T1 - ln T2`` through ``d^2`` only: at ``d = 0`` the Jacobian columns of
``ln T1`` and ``ln T2`` are the same and their linearised covariance is singular. The
pseudo-inverse then gives the difference a variance of 1e300 (an interval of T1 of
"6e+78 times its value" on an inverse response whose fitted lags were 7.30 s and 7.29 s),
and every draw from it a response 44 % off: the grader called a model right to 2 % of its
step response undetermined, and recommended a first-order model 9 % off instead.

Where the fitted difference is within its own interval of zero (the lags coincide within
the data), the covariance is made in the coordinates in which the response is smooth
there: the mean ``m = (ln T1 + ln T2) / 2`` and ``w = d^2`` (the second-order expansion of
an even function; Bates & Watts, Nonlinear Regression Analysis and Its Applications,
1988, sec. 6.1, on parameterisations whose linear approximation fails). The data
bound ``w`` from above: ``d`` lies within ``+-sqrt(w + q sd_w)``, which is given to ``d``
as a standard deviation of that over ``q``, independent of the rest, and mapped back to
``(ln T1, ln T2)``. The intervals then say what the data say: the two lags' mean is
determined, their split up to the bound.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .search import Space

#: The step in ``w = d^2`` of the one new Jacobian column (a lag ratio of e^0.01).
W_STEP = 1e-4


def lag_pair(space: Space) -> tuple[int, int] | None:
    """The coordinates of ``T1`` and ``T2`` when both are searched on log scale."""
    names = list(space.names)
    if "T1" not in names or "T2" not in names:
        return None
    i, j = names.index("T1"), names.index("T2")
    return (i, j) if space.log[i] and space.log[j] else None


def coincide(pair: tuple[int, int], z: np.ndarray, cov: np.ndarray, q: float) -> bool:
    """Whether the lags' log difference is within ``q`` of its standard errors of zero."""
    i, j = pair
    return bool(abs(z[i] - z[j]) <= q * math.sqrt(max(difference_variance(pair, cov), 0.0)))


def symmetric_jacobian(prof: Callable[[np.ndarray], tuple], jac: np.ndarray,
                       z: np.ndarray, pair: tuple[int, int]) -> np.ndarray:
    """``jac`` (the profiled residual's Jacobian at the coordinates ``z``, then the gain)
    with the lag pair's columns in ``(m, w)`` (see the module docstring): ``prof(z)[0]``
    is the profiled residual at ``z`` (:func:`pipeline.refine.refinement._profile`);
    ``w``'s column one difference of :data:`W_STEP` (one-sided at ``w = 0``)."""
    i, j = pair
    m, d0 = (z[i] + z[j]) / 2, z[i] - z[j]
    w0 = d0 * d0
    sign = 1.0 if d0 >= 0 else -1.0

    def at(w: float) -> np.ndarray:
        zz = np.array(z, dtype=np.float64)
        d = sign * math.sqrt(max(w, 0.0))
        zz[i], zz[j] = m + d / 2, m - d / 2
        return prof(zz)[0]

    up, dn = w0 + W_STEP, max(w0 - W_STEP, 0.0)
    sym = np.array(jac, dtype=np.float64)
    sym[:, i] = jac[:, i] + jac[:, j]  # d/dm: both log lags move together
    sym[:, j] = (at(up) - at(dn)) / (up - dn)
    return sym


def from_symmetric(c: np.ndarray, z: np.ndarray, pair: tuple[int, int], q: float
                   ) -> np.ndarray:
    """The covariance of ``(ln T1, ln T2)`` and the rest from ``c``, the covariance with
    the lag pair in ``(m, w)``: ``d`` within ``+-sqrt(w + q sd_w)`` at ``q`` standard
    deviations, independent of the rest (at ``d = 0`` the response's first-order
    dependence on ``d`` is nil, so is its correlation with anything)."""
    i, j = pair
    c = np.array(c, dtype=np.float64)
    w0 = float(z[i] - z[j]) ** 2
    d_max = math.sqrt(w0 + q * math.sqrt(max(c[j, j], 0.0)))
    c[j, :] = 0.0
    c[:, j] = 0.0
    c[j, j] = (d_max / q) ** 2
    a = np.eye(c.shape[0])  # (ln T1, ln T2) = (m + d/2, m - d/2)
    a[i, :] = 0.0
    a[j, :] = 0.0
    a[i, i], a[i, j], a[j, i], a[j, j] = 1.0, 0.5, 1.0, -0.5
    return a @ c @ a.T


def difference_variance(pair: tuple[int, int], cov: np.ndarray) -> float:
    """The variance of ``ln T1 - ln T2`` that ``cov`` gives."""
    i, j = pair
    return float(cov[i, i] + cov[j, j] - 2 * cov[i, j])
