"""Where the input moves: the level scan of :mod:`pipeline.segmentation` (steps 2-3).

:func:`scan` walks the input once against the current level and returns the raw events
(where each departs, where its new plateau starts or where the input is back). Every
search in it gives exactly the answer of the sample-by-sample loop it replaces
(``tests/test_edges.py`` checks each against that loop), at a cost linear in samples and
in events (``benchmarks/segment_speed.py``):

* a forward or backward search looks at chunks that double in size, so it costs about
  twice the distance to its answer, never the rest of the record;
* the look-ahead for a pulse's return (the input back at its level for ``stable`` samples)
  stops at the latest return that could still make a pulse, and skips whole blocks of
  :data:`BLOCK` samples by their precomputed window extremes (:class:`_Extremes`): a
  block none of whose windows lies within the band around the level is never read.
  Its worst case is ``O(samples / BLOCK)`` vector work per event, in blocks.

Hand-written rather than a library call because no numpy or scipy routine finds "the first
index from here where a condition holds" without evaluating it over the whole rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

#: First chunk of a doubling search (samples), and the largest (bounds the temporaries).
CHUNK, MAX_CHUNK = 256, 1 << 16
#: Window starts per block of :class:`_Extremes`.
BLOCK = 1024


@dataclass(frozen=True)
class Raw:
    """A raw event of the scan: ``kind`` "step" or "impulse", ``k`` the first sample off
    the old level (walked back to where a slow ramp began), ``j`` the first sample of the
    new plateau (step) or back on the level (impulse), ``level_before`` the level left."""

    kind: str
    k: int
    j: int
    level_before: float


def scan(t: np.ndarray, u: np.ndarray, level: float, thr: float, sigma_u: float, *,
         stable: int, pulse_fraction: float) -> list[Raw]:
    """The raw events of ``u`` from ``level`` (module docstring of
    :mod:`pipeline.segmentation`, steps 2-3).

    A departure whose input is back at its level within ``pulse_fraction`` of the time to
    the next departure is a pulse (a one- or two-sample blip under twice the threshold is
    noise); else it is a step to its plateau (:func:`as_pulse` when that plateau turns out
    to be the level it left).
    """
    n = u.size
    ext = _Extremes(u, stable)
    t_last = t[-1] + (t[-1] - t[-2])
    raws: list[Raw] = []
    k = 0
    while True:
        k = departure(u, k, level, thr)
        if k >= n:
            return raws
        lim = pulse_fraction * (t_last - t[k])  # a later return cannot make a pulse
        back = ext.first_stable(k + 1, level, thr, _first_at_least(t, k, lim))
        if back is not None and _is_pulse(t, u, k, back, level, thr, pulse_fraction, t_last):
            if not _blip(u, k, back, level, thr):
                raws.append(Raw("impulse", walk_back(u, k, level, sigma_u), back, level))
            k = back
            continue
        j = plateau_start(u, k, thr, stable, sigma_u)
        raws.append(Raw("step", walk_back(u, k, level, sigma_u), j, level))
        level = float(np.median(u[j : j + stable]))
        k = j


def as_pulse(u: np.ndarray, r: Raw, thr: float, stable: int) -> Raw | None:
    """A step raw whose plateau turned out to be the level it left (a short pulse just
    before the next change, issue 13 item 14) as the pulse it was: from its departure to
    where the input is back for ``stable`` samples (by its plateau); None when it never is
    or it is a blip (noise)."""
    k = departure(u, r.k, r.level_before, thr)  # r.k may be walked back onto the level
    # the windows from the departure to just past the plateau's start (cut where u is)
    back = _Extremes(u[k : r.j + 2 * stable], stable).first_stable(
        1, r.level_before, thr, r.j + stable + 1 - k)
    if back is None or _blip(u, k, k + back, r.level_before, thr):
        return None
    back += k
    return Raw("impulse", r.k, back, r.level_before)


def _blip(u, k, back, level, thr) -> bool:
    """A one- or two-sample blip barely over the bar: noise."""
    return back - k <= 2 and float(np.max(np.abs(u[k:back] - level))) < 2 * thr


def departure(u: np.ndarray, start: int, level: float, thr: float) -> int:
    """First index ``>= start`` where ``|u - level| > thr``, else ``u.size``."""
    n, a, chunk = u.size, start, CHUNK
    while a < n:
        b = min(n, a + chunk)
        off = np.flatnonzero(np.abs(u[a:b] - level) > thr)
        if off.size:
            return a + int(off[0])
        a, chunk = b, min(2 * chunk, MAX_CHUNK)
    return n


def _first_at_least(t: np.ndarray, k: int, lim: float) -> int:
    """First index ``i > k`` with ``t[i] - t[k] >= lim`` (exactly as computed), else n."""
    n = t.size
    i = max(k + 1, min(n, int(np.searchsorted(t, t[k] + lim))))
    while i > k + 1 and t[i - 1] - t[k] >= lim:
        i -= 1
    while i < n and t[i] - t[k] < lim:
        i += 1
    return i


def _is_pulse(t, u, k, back, level, thr, pf, t_last) -> bool:
    """``t[back] - t[k] < pf (t_next - t[k])``, ``t_next`` the time of the next departure
    from ``level`` at or after ``back`` (one sample time past the end if none). The search
    stops as soon as the answer is known (the test is monotone in ``t_next``)."""
    away, n, a, chunk = t[back] - t[k], u.size, back, CHUNK
    while a < n:
        b = min(n, a + chunk)
        off = np.flatnonzero(np.abs(u[a:b] - level) > thr)
        if off.size:
            return bool(away < pf * (t[a + int(off[0])] - t[k]))
        if b < n and away < pf * (t[b] - t[k]):
            return True  # the next departure is at b or later
        a, chunk = b, min(2 * chunk, MAX_CHUNK)
    return bool(away < pf * (t_last - t[k]))


class _Extremes:
    """Per block of :data:`BLOCK` window starts ``i``: the least of the window maxima
    ``max u[i : i + m]`` and the largest of the window minima (windows cut at the end).
    A block can hold a window within ``thr`` of a level only if the least maximum is at
    most ``level + thr`` and the largest minimum at least ``level - thr``."""

    def __init__(self, u: np.ndarray, m: int, slab: int = 256 * BLOCK) -> None:
        self.u, self.m = u, max(1, int(m))
        n, m = u.size, self.m
        nb = -(-n // BLOCK)
        self.lo, self.hi = np.empty(nb), np.empty(nb)
        for s in range(0, n, slab):  # in slabs: temporaries stay small
            e = min(n, s + slab)
            seg = u[s : min(n, e + m - 1)]
            pad = e + m - 1 - (s + seg.size)  # windows cut at the end of the record
            wmax = sliding_window_view(np.concatenate([seg, np.full(pad, -np.inf)]), m).max(1)
            wmin = sliding_window_view(np.concatenate([seg, np.full(pad, np.inf)]), m).min(1)
            fill = -(-(e - s) // BLOCK) * BLOCK - (e - s)
            q0 = s // BLOCK
            q1 = q0 + (e - s + fill) // BLOCK
            self.lo[q0:q1] = np.concatenate([wmax, np.full(fill, np.inf)]).reshape(
                -1, BLOCK).min(1)
            self.hi[q0:q1] = np.concatenate([wmin, np.full(fill, -np.inf)]).reshape(
                -1, BLOCK).max(1)

    def first_stable(self, start: int, level: float, thr: float, stop: int) -> int | None:
        """First ``i`` in ``[start, stop)`` from which ``m`` samples (or the rest of the
        record) all sit within ``thr`` of ``level``, or None."""
        stop = min(stop, self.u.size)
        if start >= stop:
            return None
        slack = 1e-9 * (abs(level) + thr)  # the block test only preselects: generous
        top, bottom = level + thr + slack, level - thr - slack
        q, q_end, step = start // BLOCK, (stop - 1) // BLOCK + 1, 16
        while q < q_end:
            q2 = min(q_end, q + step)
            cand = np.flatnonzero((self.lo[q:q2] <= top) & (self.hi[q:q2] >= bottom))
            for c in cand:
                a = max(start, (q + int(c)) * BLOCK)
                hit = self._exact(a, min(stop, a - a % BLOCK + BLOCK), level, thr)
                if hit is not None:
                    return hit
            q, step = q2, 4 * step
        return None

    def _exact(self, a: int, b: int, level: float, thr: float) -> int | None:
        u, m = self.u, self.m
        near = np.abs(u[a : min(u.size, b + m - 1)] - level) <= thr
        bad = np.concatenate([[0], np.cumsum(~near)])
        i = np.arange(b - a)
        ok = bad[np.minimum(i + m, near.size)] == bad[i]
        hit = np.flatnonzero(ok)
        return a + int(hit[0]) if hit.size else None


def walk_back(u: np.ndarray, k: int, level: float, sigma_u: float) -> int:
    """Move a departure back to where a slow ramp really began (noise-aware): step back
    while the sample before is off the level by more than the noise and less than the
    sample after it."""
    tol = max(3 * sigma_u, 1e-9 * max(1.0, abs(level)))
    hi, chunk = k, 64
    while hi > 0:
        lo = max(0, hi - chunk)
        d = np.abs(u[lo : hi + 1] - level)
        stop = np.flatnonzero(~((d[:-1] > tol) & (d[:-1] < d[1:])))
        if stop.size:
            return lo + int(stop[-1]) + 1
        hi, chunk = lo, min(2 * chunk, MAX_CHUNK)
    return 0


def plateau_start(u: np.ndarray, k: int, thr: float, m: int, sigma_u: float = 0.0,
                  m_flat: int = 10) -> int:
    """First index j >= k where the input has stopped moving: the next ``m`` samples agree
    within thr/2, and the means of the two halves of the next ``2 m_flat`` samples differ
    by no more than their noise (3 sigma) or thr/20: a slow ramp changes a little per
    sample, even under noise, but keeps moving.

    Vectorised over chunks with a slightly looser test (sums in another order), each
    candidate then confirmed by the exact test (:func:`_plateau_at`)."""
    n = u.size
    flat = max(3.0 * sigma_u * np.sqrt(2.0 / m_flat), thr / 20)
    full = n - max(m, 2 * m_flat) + 1  # from here on the windows are cut by the end
    for j in range(k, min(k + 4, full)):  # a clean step's plateau starts at once
        if _plateau_at(u, j, thr, m, flat, m_flat):
            return j
    a, chunk = min(k + 4, max(k, full)), CHUNK
    while a < full:
        b = min(full, a + chunk)
        seg = u[a : b + max(m, 2 * m_flat) - 1]
        scale = 1e-12 * float(np.max(np.abs(seg)))
        w = sliding_window_view(seg[: b - a + m - 1], m)
        ok = np.max(np.abs(w - np.median(w, axis=1)[:, None]), axis=1) <= thr / 2 + scale
        if m_flat >= m:
            v = sliding_window_view(seg[: b - a + 2 * m_flat - 1], 2 * m_flat)
            diff = np.abs(v[:, :m_flat].mean(1) - v[:, m_flat:].mean(1))
            ok &= diff <= flat * (1 + 1e-9) + scale
        for c in np.flatnonzero(ok):
            if _plateau_at(u, a + int(c), thr, m, flat, m_flat):
                return a + int(c)
        a, chunk = b, min(2 * chunk, MAX_CHUNK)
    for j in range(max(k, full), n):
        if _plateau_at(u, j, thr, m, flat, m_flat):
            return j
    return k


def _plateau_at(u, j, thr, m, flat, m_flat) -> bool:
    """The test of :func:`plateau_start` at one index, sample by sample."""
    w = u[j : j + m]
    if not np.all(np.abs(w - np.median(w)) <= thr / 2):
        return False
    v = u[j : j + 2 * m_flat]
    half = v.size // 2
    return half < m or abs(float(np.mean(v[:half]) - np.mean(v[half:]))) <= flat
