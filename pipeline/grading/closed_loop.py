"""Is the log closed-loop? The input's sample-to-sample changes against the output's
(:func:`closed_loop_flag`, a record-level finding of :mod:`pipeline.grading.verdicts`)."""

from __future__ import annotations

import numpy as np

from ..events import Event
from ..fit import Flag
from ..record import Record
from .ranks import centred, has_nan, narrowed, rank_correlation, ranks_of, sort_groups

#: Closed loop: the lag-0 rank correlation of input and output increments (times the gain's
#: sign) below minus this gives a controller away (see :func:`closed_loop_flag`).
CLOSED_LOOP_CORR = 0.3
CLOSED_LOOP_MIN_SAMPLES = 30


def closed_loop_flag(record: Record, events: list[Event]) -> Flag | None:
    """``closed_loop_suspected`` when the input's sample-to-sample changes follow the
    output's changes of the same sample, against them.

    A controller computes u[k] from y[k]: its increments answer the output's at lag 0
    (proportional action on the measured output and its noise), with the sign of -K for
    negative feedback. In an open-loop test the input is set from outside and the plant
    answers it a sample later at the earliest (zero-order hold), so the lag-0 rank
    correlation of (du, dy) is near 0 (|rho| < 0.05 measured on step tests with input and
    output noise; -0.8 to -1.0 on PI loops with and without measurement noise).
    """
    # the gain's sign from the levels: in steady state y follows K u, open or closed loop
    # (before the changes are made: its two centred copies beside them were the peak)
    cov = float((record.u - record.u.mean()) @ (record.y - record.y.mean()))  # corrcoef's
    sign = float(np.sign(cov)) or 1.0  # sign, without its stacked copies of u and y
    du, dy = np.diff(record.u), np.diff(record.y)
    moving = (du != 0) | (dy != 0)
    every = bool(moving.all())
    du, dy = (du, dy) if every else (du[moving], dy[moving])  # no needless copies
    samples = int(du.size)
    if samples < CLOSED_LOOP_MIN_SAMPLES or np.std(du) == 0 or np.std(dy) == 0 \
            or np.std(record.u) == 0 or np.std(record.y) == 0:
        return None
    # Spearman's rho with one series' changes held at a time, each made again, sorted,
    # dropped and ranked (not scipy's spearmanr, nor both series and both rankings at once)
    if has_nan(du) or has_nan(dy):
        return None  # no rank for a NaN: rho is NaN, no flag
    del du, dy
    keep = None if every else moving
    del moving
    rx = _change_ranks(record.u, keep, doubled=True)  # (integers: half the memory while
    ry = _change_ranks(record.y, keep)  # the output's are made)
    del keep
    rx = centred(rx / 2.0)
    rho = rank_correlation(rx, ry)
    if not rho * sign < -CLOSED_LOOP_CORR:
        return None
    return Flag(
        "closed_loop_suspected",
        f"The input's changes follow the output's, against them (rank correlation "
        f"{rho:+.2f} over {samples} samples): the input is set by a controller, "
        "not by a step test. Step-response readings assume the input holds its level, and "
        "a model identified in closed loop can be biased.",
        {"correlation": rho, "samples": samples})


def _change_ranks(v: np.ndarray, keep: np.ndarray | None, doubled: bool = False
                  ) -> np.ndarray:
    """The centred average ranks of ``v``'s sample-to-sample changes (at ``keep``: all
    where None; ``doubled``: twice the ranks, not centred, :func:`pipeline.grading.ranks.
    ranks_of`), the changes dropped once sorted and the order narrowed after: the other
    series' ranks, these changes and their order, each record-long, are the check's
    peak."""
    d = np.diff(v)
    if keep is not None:
        d = d[keep]
    order, new = sort_groups(d)
    del d
    order = narrowed(order)
    ranks = ranks_of(order, new, doubled)
    return ranks if doubled else centred(ranks)
