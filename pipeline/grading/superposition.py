"""Least squares of an output on superposed step responses: ``y = c + sum_j K_j x_j``
where column ``x_j`` is 0 before its event, moves over ``[start, stop)`` and holds a
constant ``delta`` after (:class:`Column`), as :func:`pipeline.grading.consistency.step_gains`
poses it, without the dense ``samples x events`` matrix.

Between consecutive column boundaries a row of X is a constant vector plus the few
columns still moving there. Two exact solvers use that:

* :func:`compressed` (up to :data:`SPARSE_FROM` columns): a QR of each segment's
  ``[1, moving]`` block turns the problem into a small stacked one with the same
  solution and ``R^T R = X^T X`` (an orthogonal change of rows: Golub & Van Loan, Matrix
  Computations, 4th ed., 2013, sec. 5.3), solved by SVD. Its stacked matrix is still
  dense in the columns that have settled, so it costs O(events^3);
* :func:`kkt` (from :data:`SPARSE_FROM` columns): a level ``l_g`` per segment, ``l_g =
  c + sum of K_j delta_j`` over the columns settled by then, turns every row into
  ``l_g + sum K_j x_j`` over the moving columns only, and the levels' definitions into
  sparse equality constraints. The equality-constrained normal equations (the KKT
  system, Golub & Van Loan sec. 6.2.4; Nocedal & Wright, Numerical Optimization, 2nd
  ed., 2006, sec. 16.1) are sparse, O(events) non-zeros, and SuperLU
  (``scipy.sparse.linalg.splu``) solves them in about linear time. The top-left block of
  the KKT inverse is the constrained covariance ``Z (Z^T H Z)^-1 Z^T`` (Z: the null space
  of the constraints, here the map from ``(c, K)`` to the levels), so the gains'
  variances are diagonal entries of it, one sparse solve per gain. A singular system
  (collinear columns) falls back to :func:`compressed`, whose SVD copes with it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..uncertainty import gram_pinv

#: From this many columns on :func:`solve` takes the sparse KKT route.
SPARSE_FROM = 150
#: Unit right-hand sides per sparse solve for the variances (memory: rows x this).
BLOCK = 256
#: The KKT route only when the columns' moving parts total at most this many times the
#: samples, and only for a well-determined answer: variance inflation below this.
OVERLAP, MAX_INFLATION = 8, 1e10


@dataclass(frozen=True)
class Column:
    """A regressor: 0 before ``start``, ``values`` on ``[start, stop)``, ``delta`` from
    ``stop`` to the end of the record. ``values`` None: ``make()`` gives them, and the
    solvers make them when a segment needs them and forget them once the column has
    settled (:class:`_Values`)."""

    start: int
    stop: int
    values: np.ndarray | None
    delta: float
    make: Callable[[], np.ndarray] | None = None


class _Values:
    """The columns' values for one solve: given ones as they are, the others made on
    demand, kept while their column moves and dropped when it settles (a pass over the
    segments in order holds the few columns moving at once, not all of them). A column
    made again gives the same values; its squared norm is kept from the first time."""

    def __init__(self, cols: list[Column]):
        self.cols = cols
        self.kept: dict[int, np.ndarray] = {}
        self.norm2: dict[int, float] = {}

    def __call__(self, j: int) -> np.ndarray:
        c = self.cols[j]
        if c.values is not None:
            return c.values
        v = self.kept.get(j)
        if v is None:
            v = self.kept[j] = c.make()
            if j not in self.norm2:
                self.norm2[j] = float(v @ v)
        return v

    def settled(self, js) -> None:
        """Forget the values of the columns ``js`` (they have reached their stop)."""
        for j in js:
            self.kept.pop(j, None)

    def squared_norm(self, j: int) -> float:
        c = self.cols[j]
        if c.values is not None:
            return float(c.values @ c.values)
        if j not in self.norm2:
            self(j)
            self.settled([j])
        return self.norm2[j]


@dataclass(frozen=True)
class Solution:
    """Coefficients ``[c, K_1 .. K_n]``, the residuals, and the diagonal of
    ``(X^T X)^+`` (the unscaled variances)."""

    coef: np.ndarray
    residuals: np.ndarray
    unscaled: np.ndarray


def solve(cols: list[Column], y: np.ndarray) -> Solution:
    """Least squares of ``y`` on ``[1, cols...]`` (see the module docstring). The KKT
    route is taken for many columns that move briefly (at most :data:`OVERLAP` times the
    samples in all: on an irregular grid they run to the end and the system would fill
    in), and its answer kept only when no gain is nearly collinear with the others
    (variance inflation below :data:`MAX_INFLATION`); else the compressed SVD solve,
    which gives the minimum-norm answer there."""
    values = _Values(cols)
    if len(cols) >= SPARSE_FROM and all(c.stop > 0 for c in cols) \
            and sum(c.stop - c.start for c in cols) <= OVERLAP * y.size:  # l_0 is c
        try:
            sol = kkt(cols, y, values)
            if np.max(sol.unscaled * _norms2(cols, y.size, values)) < MAX_INFLATION:
                return sol
        except (RuntimeError, np.linalg.LinAlgError):
            pass  # singular (collinear columns): the SVD of the compressed problem copes
    return compressed(cols, y, values)


def _norms2(cols: list[Column], n: int, values: _Values) -> np.ndarray:
    """Squared norms of ``[1, cols...]`` over the ``n`` samples: with the unscaled
    variances, each coefficient's variance inflation factor ``1 / (1 - R^2)``."""
    return np.array([float(n), *(values.squared_norm(j) + c.delta**2 * (n - c.stop)
                                 for j, c in enumerate(cols))])


def _segments(cols: list[Column], n: int):
    """``(s0, s1, settling, moving)`` for each segment between column boundaries: the
    columns that settle (reach their ``stop``) at ``s0``, and those still moving there
    (``start <= s0 < stop``), by one sweep over the boundaries."""
    cuts = sorted({0, n, *(c.start for c in cols), *(c.stop for c in cols)})
    starting: dict[int, list[int]] = {}
    stopping: dict[int, list[int]] = {}
    for j, c in enumerate(cols):
        starting.setdefault(c.start, []).append(j)
        stopping.setdefault(c.stop, []).append(j)
    active: set[int] = set()
    for s0, s1 in zip(cuts[:-1], cuts[1:], strict=True):
        active.update(starting.get(s0, ()))
        settling = stopping.get(s0, [])
        active.difference_update(settling)
        if s1 > s0:
            yield s0, s1, settling, sorted(active)


def _block(values: _Values, s0: int, s1: int, moving: list[int]) -> np.ndarray:
    """``[1, moving columns]`` over the samples ``[s0, s1)``."""
    Z = np.empty((s1 - s0, 1 + len(moving)))
    Z[:, 0] = 1.0
    for k, j in enumerate(moving):
        start = values.cols[j].start
        Z[:, k + 1] = values(j)[s0 - start: s1 - start]
    return Z


def compressed(cols: list[Column], y: np.ndarray, values: _Values | None = None
               ) -> Solution:
    """The per-segment QR and one stacked SVD solve (see the module docstring)."""
    values = values or _Values(cols)
    n, p = y.size, len(cols) + 1
    blocks, rhs, segs = [], [], []
    const = np.zeros(p)
    const[0] = 1.0
    for s0, s1, settling, moving in _segments(cols, n):
        values.settled(settling)
        for j in settling:
            const[j + 1] = cols[j].delta
        Z = _block(values, s0, s1, moving)
        Q, R = np.linalg.qr(Z)
        P = np.zeros((1 + len(moving), p))
        P[0] = const
        for k, j in enumerate(moving):
            P[k + 1, j + 1] = 1.0
        blocks.append(R @ P)
        rhs.append(Q.T @ y[s0:s1])
        segs.append((s0, s1, Z, P))
    M, r = np.vstack(blocks), np.concatenate(rhs)
    # columns scaled to unit norm first: the SVD's cut-off is relative to the largest
    # singular value, and femto-unit inputs beside the offset column would fall below it
    norm = np.maximum(np.sqrt(np.sum(M**2, axis=0)), 1e-300)
    coef = np.linalg.lstsq(M / norm, r, rcond=None)[0] / norm
    e = np.empty(n)
    for s0, s1, Z, P in segs:
        e[s0:s1] = y[s0:s1] - Z @ (P @ coef)
    return Solution(coef, e, np.diag(gram_pinv(M)).copy())


def kkt(cols: list[Column], y: np.ndarray, values: _Values | None = None) -> Solution:
    """The sparse equality-constrained normal equations (see the module docstring);
    raises RuntimeError when the system is singular."""
    from scipy import sparse
    from scipy.sparse.linalg import splu

    values = values or _Values(cols)
    n, m = y.size, len(cols)
    segs = list(_segments(cols, n))
    g_count = len(segs)
    size = g_count + m + (g_count - 1)  # levels, gains, constraints
    rows, cc, vals = [], [], []
    b = np.zeros(size)
    blocks = []
    for g, (s0, s1, settling, moving) in enumerate(segs):
        values.settled(settling)
        Z = _block(values, s0, s1, moving)
        idx = np.array([g, *(g_count + j for j in moving)])
        gram = Z.T @ Z
        rows.append(np.repeat(idx, idx.size))
        cc.append(np.tile(idx, idx.size))
        vals.append(gram.ravel())
        b[idx] += Z.T @ y[s0:s1]
        blocks.append((s0, s1, settling, moving, idx))  # Z built again for the residuals
    for g in range(1, g_count):  # l_g - l_(g-1) - sum K_j delta_j (settling at g) = 0
        r = g_count + m + g - 1
        new = segs[g][2]
        ci = [g, g - 1, *(g_count + j for j in new)]
        cv = [1.0, -1.0, *(-cols[j].delta for j in new)]
        rows.append(np.array([r] * len(ci) + ci))
        cc.append(np.array(ci + [r] * len(ci)))
        vals.append(np.array(cv + cv))
    A = sparse.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cc))),
                          shape=(size, size))
    lu = splu(A)
    x = lu.solve(b)
    if not np.all(np.isfinite(x)):
        raise RuntimeError("the KKT system is singular")
    e = np.empty(n)
    for s0, s1, settling, moving, idx in blocks:
        values.settled(settling)
        e[s0:s1] = y[s0:s1] - _block(values, s0, s1, moving) @ x[idx]
    coef = np.concatenate([[x[0]], x[g_count: g_count + m]])
    want = np.array([0, *range(g_count, g_count + m)])
    unscaled = np.empty(want.size)
    for k in range(0, want.size, BLOCK):
        part = want[k: k + BLOCK]
        unit = np.zeros((size, part.size))
        unit[part, np.arange(part.size)] = 1.0
        unscaled[k: k + part.size] = lu.solve(unit)[part, np.arange(part.size)]
    if not np.all(np.isfinite(unscaled)) or np.any(unscaled < 0):
        raise RuntimeError("the KKT system is singular")
    return Solution(coef, e, unscaled)
