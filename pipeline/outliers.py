"""Single-sample outliers of the output (issue 27 item 6): a sensor glitch (one 0.0 read
in a log near 6, say) is named and ignored by the analysis, not read as a drift of the
baseline or a misfit of every model.

A sample is an outlier when it lies more than :data:`OUTLIER_SIGMAS` noise sigmas (and
:data:`OUTLIER_RANGE` of the output's range) off the 5-sample running median, which
follows steps, ramps and responses but not a run of one or two samples (Tukey's
running median, *Exploratory Data Analysis*, 1977, ch. 7). The noise is the robust
scale of the first differences (``1.4826 MAD / sqrt 2``), at least the smallest step
the sensor resolves. A sample within :data:`AFTER_INPUT` samples after an input change
is never one (a fast plant's own answer to a pulse, however late its dead time). More than
:data:`MAX_SHARE` of the samples is the signal's nature, not glitches: none is taken.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.ndimage import median_filter

from .record import Record

OUTLIER_SIGMAS = 10.0
OUTLIER_RANGE = 0.02
#: Samples after an input change that are never outliers: a fast plant's answer to a
#: one-sample pulse is a spike of a sample or two, as late as its dead time (review: with
#: 3 samples, a 0.6 s delay on a 0.1 s grid lost the whole response, K 0.107 for 2).
AFTER_INPUT = 100
MAX_SHARE = 0.01
#: The running median's width: runs of up to (WIDTH - 1)/2 samples are outliers.
WIDTH = 5


def _scale(x: np.ndarray, resolution: bool = True) -> float:
    """The noise sigma read from the first differences, robust to steps and spikes; with
    ``resolution`` at least the smallest step the signal makes (a quantised sensor)."""
    d = np.diff(x)
    mad = float(np.median(np.abs(d - np.median(d))))
    quantum = float(np.min(np.abs(d[d != 0]))) if resolution and np.any(d != 0) else 0.0
    return max(1.4826 * mad / np.sqrt(2.0), quantum)


def find_outliers(u: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(indices, replacements)``: the output's single-sample outliers (see the module
    docstring) and the running median's value at each (pure)."""
    none = np.zeros(0, dtype=np.int64), np.zeros(0)
    if y.size < 4 * WIDTH:
        return none
    med = median_filter(y, size=WIDTH, mode="mirror")  # an end sample is not its own pad
    dev = np.abs(y - med)
    lo, hi = np.percentile(y, [0.5, 99.5])
    limit = max(OUTLIER_SIGMAS * _scale(y), OUTLIER_RANGE * float(hi - lo))
    out = dev > limit
    idx = np.flatnonzero(out)
    if idx.size == 0 or idx.size > MAX_SHARE * y.size:
        return none
    # isolated: a neighbour that is no outlier itself lies near its own median (a peak
    # of a ring sampled a few times a period drags its neighbours off theirs too)
    calm = ~out & (dev < 0.5 * limit)
    left = np.concatenate(([True], calm[:-1] | out[:-1]))
    right = np.concatenate((calm[1:] | out[1:], [True]))
    near_l = np.concatenate(([True], calm[:-1]))
    near_r = np.concatenate((calm[1:], [True]))
    idx = idx[left[idx] & right[idx] & (near_l[idx] | near_r[idx])]
    du = np.abs(np.diff(u, prepend=u[0]))
    moved = du > max(OUTLIER_SIGMAS * _scale(u, resolution=False),
                     1e-9 * float(np.max(np.abs(u))))
    if np.any(moved):
        # a sample at most AFTER_INPUT after an input change is the plant's own answer
        recent = np.convolve(moved.astype(np.int8), np.ones(AFTER_INPUT + 1, np.int8))
        idx = idx[recent[idx] == 0]
    return idx, med[idx]


def without_outliers(record: Record) -> Record:
    """``record`` with its output's outliers replaced by their running median, and the
    rows and their values kept in ``outliers`` for the ``outlier_samples`` flag; the
    record itself when it has none."""
    idx, values = find_outliers(record.u, record.y)
    if idx.size == 0:
        return record
    y = record.y.copy()
    kept = tuple((int(i), float(y[i]), float(v)) for i, v in zip(idx, values, strict=True))
    y[idx] = values
    y.setflags(write=False)
    return replace(record, y=y, outliers=kept)
