"""Spearman's rank correlation of two long series, lean in memory.

``scipy.stats.spearmanr`` stacks both series, ranks them with ``apply_along_axis`` and
keeps several record-long temporaries alive at once: about 1.2 GB for the 10 M
sample-to-sample changes of a plant-historian log (:func:`pipeline.grade.closed_loop_flag`),
five times the record's own arrays (issue 14). Here each series is ranked on its own
(average ranks for ties, as ``scipy.stats.rankdata(method="average")``) and the
temporaries are dropped as soon as they are used; the statistic is the Pearson
correlation of the ranks (Spearman's rho with ties: Kendall & Gibbons, Rank Correlation
Methods, 5th ed., 1990, sec. 3.8), the same as scipy's to rounding.
"""

from __future__ import annotations

import math

import numpy as np


def average_ranks(x: np.ndarray) -> np.ndarray:
    """Ranks 1..n of ``x``, ties given the mean of the ranks they span (int32 positions
    and no per-sample group labels: three record-long temporaries at most)."""
    n = x.size
    order = np.argsort(x, kind="stable")
    if n < 2**31:
        order = order.astype(np.int32)
    xs = x[order]
    new = np.empty(n, bool)
    new[:1] = True
    np.not_equal(xs[1:], xs[:-1], out=new[1:])
    del xs
    starts = np.flatnonzero(new)
    del new
    ranks = np.empty(n)
    if starts.size == n:  # no ties (a noisy output's changes): the positions themselves
        ranks[order] = np.arange(1.0, n + 1.0)
        return ranks
    ends = np.r_[starts[1:], n]
    mean_rank = (starts + ends + 1) / 2.0  # (first + last) / 2, 1-based
    ranks[order] = np.repeat(mean_rank, ends - starts)
    return ranks


def spearman(x: np.ndarray, y: np.ndarray) -> float:
    """Spearman's rho of ``x`` and ``y`` (NaN when either is constant or holds a NaN)."""
    if np.isnan(np.dot(x, x)) or np.isnan(np.dot(y, y)):
        return math.nan  # scipy's answer; a NaN has no rank
    rx = average_ranks(np.asarray(x, np.float64))
    rx -= rx.mean()
    ry = average_ranks(np.asarray(y, np.float64))
    ry -= ry.mean()
    den = math.sqrt(float(rx @ rx) * float(ry @ ry))
    return float(rx @ ry) / den if den > 0 else math.nan
