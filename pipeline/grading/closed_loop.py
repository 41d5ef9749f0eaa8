"""Is the log closed-loop? The input's sample-to-sample changes against the output's
(:func:`closed_loop_flag`, a record-level finding of :mod:`pipeline.grading.verdicts`).

A controller computes ``u[k]`` from the measured ``y[k]``: its proportional (and
derivative) action answers the output's change of the same sample, against it,
``du[k] ~ -Kc dy[k]``, on every sample where the measurement moves (its noise included).
In an open-loop test the input is set from outside and the plant answers it a sample
later at the earliest (zero-order hold), so the changes of one sample are unrelated
(unless the input is noisy and the plant answers within a sample or two: then the
differenced input noise shows through, as below).

The statistic is the uncentred correlation of the changes' signed ranks (each change's
rank by size among the non-zero ones, with its sign; Wilcoxon's signed ranks, W. J.
Conover, Practical Nonparametric Statistics, 3rd ed., 1999, sec. 5.7): a change has its
own zero, no change, so an input that moves while the output rests (a ramped step before
a long dead time) and an output that moves while the input rests add nothing. The
Spearman correlation used before centred the ranks on their medians, which turned those
two quiet halves into a correlation of -0.38 on a real pipe's ramped inlet step.

Which sign is "against" is the plant's: the levels' covariance gives it for a stable plant
in open loop, but in closed loop it is the controller's: around an integrating or an
open-loop-unstable plant, or rejecting loads at a fixed setpoint, the levels move against
each other while the loop acts with the plant's high-frequency sign. So the check also
fires, whatever the levels say, on a correlation of the same sample that is (nearly) an
exact proportion, or strongly negative and sharper than its neighbours at one sample
either side (a controller's answer to measurement noise: smooth open-loop co-movement
spreads over neighbouring samples). The thresholds are set on ``benchmarks/
closed_loop_check.py``: PI, PID and P loops around first-order, two-lag, integrating and
unstable plants, setpoint and load steps, 1-3 % white and AR(1) measurement noise, all
flagged; 876 open-loop records (delays up to 5 T, input steps ramped over up to 3 T,
white, AR(1) and 1/f noise, quantised outputs, fast plants logged in the sample they
answer in) none, but one known false alarm: a plant of negative gain that answers within
the sample it is logged in, with a noisy input, looks at lags -1..1 exactly like a
controller answering measurement noise (36 of the bench's 36 such records; the
levels' sign cannot tell, since the unstable and integrating loops share it).
"""

from __future__ import annotations

import math

import numpy as np

from ..events import Event
from ..fit import Flag
from ..memory import CHUNK
from ..record import Record
from .ranks import has_nan, narrowed, ranks_of, sort_groups

#: Against the levels' sign: a lag-0 signed-rank correlation below minus this (see
#: :func:`closed_loop_flag`).
CLOSED_LOOP_CORR = 0.3
#: Whatever the levels' sign: a correlation below minus this (a near-exact proportion)...
CLOSED_LOOP_EXACT = 0.8
#: ... or below minus this and at least :data:`CLOSED_LOOP_SHARP` below the correlation
#: one sample either side.
CLOSED_LOOP_STRONG = 0.4
CLOSED_LOOP_SHARP = 0.3
#: Every threshold is at least this many standard errors ``1/sqrt(n)`` of an unrelated
#: pair of series of ``n`` moving samples.
CLOSED_LOOP_SE = 3.0
CLOSED_LOOP_MIN_SAMPLES = 30


def closed_loop_flag(record: Record, events: list[Event]) -> Flag | None:
    """``closed_loop_suspected`` when the input's sample-to-sample changes follow the
    output's changes of the same sample, against them (see the module docstring), and
    always for a log that declares its setpoint (``data.setpoint``): its input is a
    controller's output by the user's word."""
    if record.r is not None:
        return Flag(
            "closed_loop_suspected",
            f"The log declares its setpoint ('{record.setpoint_name}', data.setpoint): the "
            "input is a controller's output, not a step test. The models are fitted from "
            "the input to the output as in open loop (the direct approach), which is "
            "biased where the measurement noise feeds back through the controller.",
            {"declared": record.setpoint_name})
    du, dy = np.diff(record.u), np.diff(record.y)
    samples = int(np.count_nonzero((du != 0) | (dy != 0)))
    if samples < CLOSED_LOOP_MIN_SAMPLES or not np.any(du) or not np.any(dy) \
            or has_nan(du) or has_nan(dy):
        return None  # nothing moves, or a NaN (no rank): no flag
    del du, dy
    su = _signed_ranks(np.diff(record.u))
    sy = _signed_ranks(np.diff(record.y))
    den = math.sqrt(_dot(su, su) * _dot(sy, sy))
    lag0 = _dot(su, sy) / den
    before = _dot(su[1:], sy[:-1]) / den  # the input's change after the output's
    after = _dot(su[:-1], sy[1:]) / den  # the output's change after the input's
    del su, sy
    # the gain's sign from the levels: in steady state y follows K u in open loop
    cov = float((record.u - record.u.mean()) @ (record.y - record.y.mean()))
    sign = float(np.sign(cov)) or 1.0
    floor = CLOSED_LOOP_SE / math.sqrt(samples)
    against = lag0 * sign < -max(CLOSED_LOOP_CORR, floor)
    exact = lag0 < -max(CLOSED_LOOP_EXACT, floor)
    sharp = lag0 < -max(CLOSED_LOOP_STRONG, floor) \
        and lag0 - min(before, after) < -CLOSED_LOOP_SHARP
    if not (against or exact or sharp):
        return None
    return Flag(
        "closed_loop_suspected",
        f"The input's changes follow the output's of the same sample, against them "
        f"(signed-rank correlation {lag0:+.2f} over {samples} samples): the input is set "
        "by a controller, not by a step test. Step-response readings assume the input "
        "holds its level, and a model identified in closed loop can be biased.",
        {"correlation": lag0, "samples": samples})


def _signed_ranks(d: np.ndarray) -> np.ndarray:
    """Twice Wilcoxon's signed ranks of the changes ``d``, as integers (exact: an average
    rank is a whole or a half number): the rank of ``|d|`` among the non-zero changes
    (average ranks for ties; 1 the smallest) with the sign of ``d``, 0 for no change.
    ``d`` is taken over (its magnitude is sorted in its place), and the ranks are made in
    the sort order's 32-bit type (:func:`pipeline.grading.ranks.ranks_of`): at 10 M
    samples the check's peak stays near the raw arrays' size, as the Spearman version's
    did (float ranks and the 64-bit order beside them took 1.7x)."""
    sign = np.signbit(d)
    np.abs(d, out=d)
    order, new = sort_groups(d)
    # zeros are the lowest group: its size is where the second group starts
    rest = np.flatnonzero(new[1:])
    zeros = 0 if d[order[0]] != 0 else (int(rest[0]) + 1 if rest.size else d.size)
    del d, rest
    order = narrowed(order)
    ranks = ranks_of(order, new, doubled=True)
    del new
    ranks -= 2 * zeros
    for a in range(0, zeros, CHUNK):
        ranks[order[a: min(a + CHUNK, zeros)]] = 0
    del order
    np.negative(ranks, out=ranks, where=sign)
    return ranks


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """``a @ b`` of two integer rank arrays in float64, a chunk at a time (an integer
    product would overflow; whole float copies would double the peak)."""
    return sum(float(a[i: i + CHUNK].astype(np.float64) @ b[i: i + CHUNK].astype(np.float64))
               for i in range(0, a.size, CHUNK))
