"""Average ranks of a long series, lean in memory.

``scipy.stats.rankdata`` keeps several record-long temporaries alive at once: for the
sample-to-sample changes of a long log (the signed ranks of
:func:`pipeline.grading.closed_loop.closed_loop_flag`), several times the record's own
arrays. Here the sort order and where its values change are made first, the series can
be dropped, and the ranks (average ranks for ties, as ``scipy.stats.rankdata(method=
"average")``) are filled a chunk at a time.
"""

from __future__ import annotations

import numpy as np

from ..memory import CHUNK


def average_ranks(x: np.ndarray) -> np.ndarray:
    """Ranks 1..n of ``x``, ties given the mean of the ranks they span (as
    ``scipy.stats.rankdata(method="average")``): :func:`ranks_of` :func:`sort_groups`."""
    order, new = sort_groups(x)
    return ranks_of(narrowed(order), new)


def sort_groups(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(order, new)``: a sort order of ``x`` and where a sorted value differs from the
    one before it, compared a chunk at a time; all that :func:`ranks_of` needs, so a
    caller can drop ``x`` before the ranks are made (and then narrow the order,
    :func:`narrowed`). The order within a group of ties is numpy's default sort's (not a
    stable one's, which took a buffer of half the order and twice the time): every
    position of a group gets the group's average rank, whatever their order. ``x``
    holds no NaN (the callers check, :func:`has_nan`): each NaN would be a group of its
    own, ranked in the sort's order."""
    n = x.size
    order = np.argsort(x)
    new = np.empty(n, bool)
    new[:1] = True
    for a in range(0, n - 1, CHUNK):
        b = min(a + CHUNK, n - 1)
        xs = x[order[a : b + 1]]
        np.not_equal(xs[1:], xs[:-1], out=new[a + 1 : b + 1])
    return order, new


def narrowed(order: np.ndarray) -> np.ndarray:
    """``order`` as 32-bit positions where they fit (half its memory: the ranks are made
    beside it)."""
    return order.astype(np.int32) if order.size < 2**31 else order


def ranks_of(order: np.ndarray, new: np.ndarray, doubled: bool = False) -> np.ndarray:
    """The average ranks from :func:`sort_groups`, each position's group of ties (its
    first and last sorted position) found and the ranks filled a chunk at a time: the
    ranks are the one record-long array made, beside the groups' starts in the order's
    integer type (no record-long ``starts``, ``ends`` or ``(starts + ends + 1) / 2``);
    the same values as whole-array passes. ``doubled``:
    twice the ranks, as integers (exact: an average rank is a whole or a half number) in
    the order's type where they fit, half the float ranks' memory with a 32-bit order;
    halved, they are the ranks to the bit."""
    n = order.size
    whole = np.int32 if order.dtype == np.int32 and n < 2**30 else np.int64
    ranks = np.empty(n, whole if doubled else np.float64)
    count = int(np.count_nonzero(new))
    if count == n:  # no ties (a noisy output's changes): the positions
        for a in range(0, n, CHUNK):
            b = min(a + CHUNK, n)
            ranks[order[a:b]] = (np.arange(2 * a + 2, 2 * b + 2, 2, dtype=whole) if doubled
                                 else np.arange(a + 1.0, b + 1.0))
        return ranks
    starts = np.empty(count + 1, order.dtype)  # each group's first position, then n
    k = 0
    for a in range(0, n, CHUNK):
        first = np.flatnonzero(new[a : a + CHUNK])
        starts[k : k + first.size] = first + a
        k += first.size
    starts[count] = n
    for a in range(0, n, CHUNK):
        b = min(a + CHUNK, n)
        group = np.searchsorted(starts[:count], np.arange(a, b, dtype=order.dtype),
                                side="right") - 1
        first, end = starts[group].astype(np.int64), starts[group + 1].astype(np.int64)
        twice = first + end + 1  # first + last, 1-based
        ranks[order[a:b]] = twice if doubled else twice / 2.0
    return ranks


def has_nan(x: np.ndarray) -> bool:
    """Whether ``x`` holds a NaN (a NaN has no rank: scipy's answer is NaN)."""
    return bool(np.isnan(np.dot(x, x)))


