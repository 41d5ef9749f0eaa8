"""Work shared by the methods of one event, done once.

Every graphical step method reads the same normalised response ``h = (y - y0)/dy`` of an
event, smoothed the same way, and most take its slope somewhere. Computed by each method
for itself, an event would be smoothed once for every reading. Here:

* :class:`Response` - a sampled response ``(tau, h, sigma)`` with its smoothed copy
  (:func:`pipeline.signal.smooth`) and the slope of that copy computed once, on first use
  (``functools.cached_property``), and the readings of :mod:`pipeline.signal` taken on
  them (:meth:`Response.crossing`, :meth:`Response.value_at`, :meth:`Response.extremum`).
  The arrays are read-only: one object is shared by every method that reads it.
* :func:`per_event` - a decorator that computes a reading of an event once per event
  object and hands the same result (or the same :class:`~pipeline.errors.NotApplicable`
  reason) to every later call. An :class:`~pipeline.events.EventData` is immutable, so
  the result cannot go stale; the cache entry goes with the event (a weak reference).

The readings are the same function calls on the same arrays as each method's own, so
the results are identical to the bit; only the repetitions are gone.
"""

from __future__ import annotations

import functools
import threading
import weakref
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import cached_property
from typing import Any, TypeVar

import numpy as np

from ..errors import NotApplicable
from ..signal import NOISE_FREE, crossing_time, extremum, smooth, value_at

R = TypeVar("R")


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if a.flags.writeable:
        a = a.copy() if a.base is not None else a
        a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Response:
    """A sampled response and what every reading of it needs, computed once.

    ``tau``: times (s, since the event's t0); ``h``: the response (a fraction of its
    change for a step, of its peak for a pulse); ``sigma``: its noise in units of ``h``.
    ``hs``: ``h`` smoothed where it is noisy (:func:`pipeline.signal.smooth`; ``h``
    itself when noise-free); ``slope``: ``d hs / d tau`` (``numpy.gradient``).
    Unpacks as ``tau, h, sigma``.
    """

    tau: np.ndarray
    h: np.ndarray
    sigma: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "tau", _frozen(self.tau))
        object.__setattr__(self, "h", _frozen(self.h))

    def __iter__(self) -> Iterator[Any]:
        return iter((self.tau, self.h, self.sigma))

    @cached_property
    def hs(self) -> np.ndarray:
        hs = smooth(self.h, self.sigma)
        return hs if hs is self.h else _frozen(hs)

    @cached_property
    def slope(self) -> np.ndarray:
        return _frozen(np.gradient(self.hs, self.tau))

    @property
    def noisy(self) -> bool:
        return self.sigma > NOISE_FREE

    def crossing(self, level: float, *, start: int = 0, falling: bool = False,
                 name: str = "") -> float:
        """:func:`pipeline.signal.crossing_time` of ``level`` on this response."""
        return crossing_time(self.tau, self.h, level, self.sigma, start=start,
                             falling=falling, name=name, hs=self.hs,
                             slope=self.slope if self.noisy else None)

    def value_at(self, t: float) -> float:
        """:func:`pipeline.signal.value_at` on this response."""
        return value_at(self.tau, self.h, t, self.sigma, hs=self.hs,
                        slope=self.slope if self.noisy and self.h.size >= 7 else None)

    def extremum(self, lo: int, hi: int, *, kind: str = "max") -> tuple[float, float, int]:
        """:func:`pipeline.signal.extremum` in samples ``[lo, hi)`` of this response."""
        return extremum(self.tau, self.h, lo, hi, self.sigma, kind=kind, hs=self.hs)


_CACHE: dict[int, tuple[weakref.ref, dict]] = {}
#: Re-entrant: a weak-reference callback (an event being freed) may run while it is held.
_LOCK = threading.RLock()


def _readings(ev) -> dict:
    """The cache of readings of ``ev`` (created on first use, dropped with ``ev``)."""
    key = id(ev)
    with _LOCK:
        entry = _CACHE.get(key)
        if entry is not None and entry[0]() is ev:
            return entry[1]
        ref = weakref.ref(ev, lambda _r, key=key: _drop(key, _r))
        readings: dict = {}
        _CACHE[key] = (ref, readings)
        return readings


def _drop(key: int, ref: weakref.ref) -> None:
    with _LOCK:
        entry = _CACHE.get(key)
        if entry is not None and entry[0] is ref:
            del _CACHE[key]


def per_event(func: Callable[..., R]) -> Callable[..., R]:
    """Compute ``func(ev, *args)`` once per event object (and arguments): later calls get
    the same result, or the same :class:`NotApplicable` reason raised anew. Any other
    exception is not kept (the next call tries again)."""

    @functools.wraps(func)
    def wrapper(ev, *args):
        readings = _readings(ev)
        key = (func.__qualname__, args)
        if key not in readings:
            try:
                readings[key] = (True, func(ev, *args))
            except NotApplicable as exc:
                readings[key] = (False, exc.reason)
        ok, value = readings[key]
        if not ok:
            raise NotApplicable(value)
        return value

    return wrapper
