"""Exact binary scaling of records whose magnitudes are extreme (issue 13 item 15).

Segmentation squares values, takes fourth differences and sums them over millions of
samples, and fits quadratics in time (fourth powers of time summed): near ``1e308`` those
overflow, near ``1e-308`` they underflow. A record beyond :data:`VALUE_RANGE` (values) or
:data:`TIME_RANGE` (times) is segmented scaled by powers of two, which is exact, and its
events are read back in the record's units (:class:`Scale`). Records within the ranges
(every real log) are untouched, so their results do not change.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..events import Event
from ..record import Record

#: Values beyond this magnitude (or under its inverse) are scaled by a power of two before
#: segmenting: squares, fourth differences and their sums over a long record stay finite
#: and normal. Times beyond the second (their fourth powers are summed) likewise.
VALUE_RANGE, TIME_RANGE = 2.0 ** 400, 2.0 ** 200


def exponent(m: float, limit: float = VALUE_RANGE) -> int:
    """``e`` with ``m / 2**e`` in [0.5, 1) when ``m`` lies outside [1/limit, limit], else 0."""
    if not math.isfinite(m) or m <= 0 or 1.0 / limit <= m <= limit:
        return 0
    return math.frexp(m)[1]


@dataclass(frozen=True)
class Scale:
    """Binary exponents that bring time, input and output to moderate magnitudes; scaling
    by powers of two is exact, so the events read back are those of the scaled record."""

    t: int = 0
    u: int = 0
    y: int = 0

    @classmethod
    def of(cls, record: Record) -> Scale:
        t, u = record.t, record.u
        big = max(abs(float(t[0])), abs(float(t[-1])))
        span = float(t[-1] - t[0])
        et = (exponent(big, TIME_RANGE) if big > TIME_RANGE
              else exponent(span, TIME_RANGE) if span < 1.0 / TIME_RANGE else 0)
        m_u = float(np.max(np.abs(u)))
        if record.initial_input is not None:
            m_u = max(m_u, abs(record.initial_input))
        return cls(et, exponent(m_u, VALUE_RANGE),
                   exponent(float(np.max(np.abs(record.y))), VALUE_RANGE))

    @property
    def needed(self) -> bool:
        return bool(self.t or self.u or self.y)

    def record(self, r: Record) -> Record:
        ii = None if r.initial_input is None else math.ldexp(r.initial_input, -self.u)
        return replace(r, t=np.ldexp(r.t, -self.t), u=np.ldexp(r.u, -self.u),
                       y=np.ldexp(r.y, -self.y), initial_input=ii)

    def back(self, e: Event) -> Event:
        et, eu, ey = self.t, self.u, self.y
        return replace(
            e, t0=math.ldexp(e.t0, et), t_end=math.ldexp(e.t_end, et),
            u0=math.ldexp(e.u0, eu), u_ss=math.ldexp(e.u_ss, eu), y0=math.ldexp(e.y0, ey),
            y_ss=math.ldexp(e.y_ss, ey), area=math.ldexp(e.area, eu + et),
            duration=math.ldexp(e.duration, et), noise=math.ldexp(e.noise, ey),
            slope=math.ldexp(e.slope, ey - et), drift=math.ldexp(e.drift, ey - et),
            tail=math.ldexp(e.tail, ey))
