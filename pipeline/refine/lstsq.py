"""Linear-algebra pieces of the separable least squares in :mod:`pipeline.refine`: block
means for decimating a long fit, a rank-revealing solve of the linear parameters, and the
projection that removes them (variable projection, Golub and Pereyra 1973)."""

from __future__ import annotations

import math

import numpy as np


def block_means(v: np.ndarray, m: int) -> np.ndarray:
    """Means of consecutive blocks of ``m`` samples (the held input of a decimated grid)."""
    idx = np.arange(0, v.size, m)
    return np.add.reduceat(v, idx) / np.diff(np.r_[idx, v.size])


def runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The maximal runs of true samples of ``mask``: their first positions and the
    positions after their last. From the mask's one-byte differences: a long span's fit
    samples as an index array (and its differences) would be 16 bytes a sample, these
    are two."""
    m = np.asarray(mask, bool)
    if m.size == 0:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    d = np.diff(m.view(np.int8))
    first = np.flatnonzero(d == 1) + 1
    after = np.flatnonzero(d == -1) + 1
    del d
    if m[0]:
        first = np.r_[0, first]
    if m[-1]:
        after = np.r_[after, m.size]
    return first, after


def blocks(mask: np.ndarray, max_rows: int) -> tuple[np.ndarray, np.ndarray]:
    """Row starts and sizes: blocks of ``ceil(n / max_rows)`` consecutive fit samples that
    never straddle a gap in ``mask`` (starts as indices into the fit samples), from the
    mask's :func:`runs`."""
    first, after = runs(mask)
    offsets = np.r_[0, np.cumsum(after - first)]  # fit-sample index of each run's start
    total = int(offsets[-1])
    m = max(1, math.ceil(total / max_rows))
    if m == 1:
        return np.arange(total), np.ones(total)
    starts = np.concatenate([np.arange(a, b, m) for a, b in zip(offsets[:-1], offsets[1:],
                                                                strict=True)])
    return starts, np.diff(np.r_[starts, total]).astype(float)


def block_bounds(mask: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(bounds, keep)``: the blocks of :func:`blocks` (starting at fit-sample indices
    ``starts``) as ``numpy.add.reduceat`` boundaries in the span, with the first sample
    of every gap of ``mask`` after a block as a boundary too, and which of the reduced
    blocks are the rows (the others are the gaps)."""
    first, after = runs(mask)
    if first.size == 0:
        return np.zeros(0, int), np.zeros(0, int)
    offsets = np.r_[0, np.cumsum(after - first)]
    run = np.searchsorted(offsets, starts, side="right") - 1  # the run each block is in
    at = first[run] + (starts - offsets[run])  # its first sample's position in the span
    gaps = after[after < np.size(mask)]  # a run of fit samples ends here
    bounds = np.union1d(at, gaps)
    return bounds, np.searchsorted(bounds, at)


def solve(a: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, int]:
    """Least-squares coefficients of ``a c = y`` (columns scaled, rank-revealing SVD)."""
    scale = np.sqrt(np.add.reduce(a * a, axis=0))  # numpy.linalg.norm(a, axis=0), without
    # its dispatch (a fifth of this solve's time; on every residual evaluation)
    scale[scale == 0] = 1.0
    c, _, rank, _ = np.linalg.lstsq(a / scale, y, rcond=1e-9)
    return c / scale, int(rank)


def project_out(nuis: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the span of ``nuis`` (numerically rank-revealed)."""
    u, s, _ = np.linalg.svd(nuis / np.maximum(np.linalg.norm(nuis, axis=0), 1e-300),
                            full_matrices=False)
    return u[:, s > 1e-9 * s[0]] if s.size and s[0] > 0 else u[:, :0]


# -- the fit -----------------------------------------------------------------------------
