"""``Event`` (what segmentation found) and ``EventData`` (what a method reads).

An :class:`Event` indexes into its record: the sample window ``[i_start, i_end)`` begins at
the first sample where the input has moved (``t0``) and runs to the next event or the end
of the record; ``i_base`` is the first sample of the settled stretch before ``t0`` whose
mean is ``y0``.

An :class:`EventData` is the self-contained slice a method works on: the arrays from
``i_base`` to ``i_end`` and the operating-point values.
:func:`pipeline.segmentation.event_data` builds one from plain numpy arrays, so every
method runs without the CLI.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .schema import EventKind, Response

#: A response whose excursion (:meth:`EventData.excursion`) passes this many noise sigmas
#: moved (the rise's own test uses 3 sigmas on the final change; a peak, the largest of
#: many samples, needs more).
MOVED_SIGMAS = 10.0


@dataclass(frozen=True)
class Event:
    """One step or impulse found in a record (DESIGN.md "Core types")."""

    index: int
    kind: EventKind
    i_start: int
    i_end: int
    i_base: int
    t0: float
    t_end: float
    u0: float
    u_ss: float  # step: level after; impulse: the baseline (== u0)
    y0: float
    y_ss: float
    area: float = 0.0  # impulse: integral of (u - u0) dt (zero-order hold)
    duration: float = 0.0  # impulse: how long the input stayed off its baseline
    settled: bool = True
    noise: float = 0.0  # output noise standard deviation estimate
    response: Response = "settling"  # how the output responds (pipeline.segmentation)
    slope: float = 0.0  # output slope over the last half of the window (units/s)
    drift: float = 0.0  # output slope before t0 (units/s; 0 unless significant)
    #: the change of the previous response when it was still settling at t0 (the output
    #: then goes on moving that way for a while), 0 when it had settled or there is none
    tail: float = 0.0


@dataclass(frozen=True)
class EventData:
    """The arrays and operating point of one event, as a method sees them.

    ``t, u, y`` cover the settled baseline before ``t0`` and the event window after it.
    ``response``, ``slope`` and ``drift`` say whether the output settles, ramps or shifts
    its level, and how fast it moves at the end of the window and before ``t0``
    (:mod:`pipeline.segmentation` step 6).
    """

    kind: EventKind
    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    t0: float
    u0: float
    u_ss: float
    y0: float
    y_ss: float
    area: float = 0.0
    duration: float = 0.0
    noise: float = 0.0
    settled: bool = True
    index: int = 0
    response: Response = "settling"
    slope: float = 0.0
    drift: float = 0.0
    tail: float = 0.0

    @classmethod
    def from_event(cls, record, event: Event) -> EventData:
        sl = slice(event.i_base, event.i_end)
        return cls(
            kind=event.kind, t=record.t[sl], u=record.u[sl], y=record.y[sl], t0=event.t0,
            u0=event.u0, u_ss=event.u_ss, y0=event.y0, y_ss=event.y_ss, area=event.area,
            duration=event.duration, noise=event.noise, settled=event.settled,
            index=event.index, response=event.response, slope=event.slope, drift=event.drift,
            tail=event.tail,
        )

    # -- views a method needs -----------------------------------------------------------
    @property
    def i0(self) -> int:
        """Index of the first sample at or after ``t0``."""
        return int(np.searchsorted(self.t, self.t0 - 1e-9 * max(1.0, abs(self.t0))))

    @property
    def du(self) -> float:
        return self.u_ss - self.u0

    @property
    def dy(self) -> float:
        return self.y_ss - self.y0

    def after(self) -> tuple[np.ndarray, np.ndarray]:
        """Time since ``t0`` and output deviation ``y - y0`` from ``t0`` on."""
        i = self.i0
        return self.t[i:] - self.t0, self.y[i:] - self.y0

    def excursion(self) -> float:
        """The largest deviation ``|y - y0|`` after ``t0`` of the output's 5-sample running
        median (output units; a glitch of one or two samples is no excursion), or 0 when
        it is within three times the same reading over the samples before ``t0`` (a
        coloured noise wanders as far before the step as after it)."""
        from scipy.ndimage import median_filter

        r = median_filter(self.y - self.y0, size=5, mode="nearest")
        after, before = r[self.i0:], r[:self.i0]
        if not after.size:
            return 0.0
        peak = float(np.max(np.abs(after)))
        if before.size >= 10 and peak <= 3.0 * float(np.max(np.abs(before))):
            return 0.0
        return peak

    def unchanged_reason(self) -> str:
        """Why a step shows no final change to read (``|y_ss - y0| <= 3 sigma``), true
        to what the output did: it did not move, or it moved and came back (a response
        with zero static gain, which no structure of the table represents: issue 27
        item 6)."""
        peak = self.excursion()
        if self.noise > 0 and peak > MOVED_SIGMAS * self.noise:
            return (f"the output moved (by up to {peak:.3g}, {peak / self.noise:.0f} noise "
                    f"sigmas) and came back: no final change to read (|y_ss - y0| <= 3 "
                    f"sigma), a response with zero static gain")
        return "the output did not change measurably (|y_ss - y0| <= 3 sigma)"
