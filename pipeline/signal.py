"""The signal toolbox: reading a sampled, noisy response robustly (DESIGN.md "signal.py").

Used by segmentation and by every method alike; pure functions on numpy arrays.

The sources read values "off the graph" (seed 001: "identifying this point on the graph";
seed 002: t33, t70, ...). On a sampled, noisy record that reading is done here:

* :func:`noise_sigma` - the output noise level, from high-order differences (robust to
  steps and spikes).
* :func:`smooth` - Savitzky-Golay smoothing, only where there is noise.
* :func:`crossing_time` - the time a response first reaches a fraction of its change.
  Noise-free: linear interpolation between the two samples around the crossing.
  Noisy: a preliminary crossing on a smoothed copy, refined by a local quadratic
  least-squares fit of the raw samples around it (many samples average the noise; the
  quadratic removes the curvature bias of a straight line). A first noisy sample across
  the level does not decide the reading.
* :func:`value_at` - the response at a given time (a symmetric local parabola).
* :func:`extremum` - a peak or valley, refined the same way (vertex of a local parabola).
* :func:`interp_cross` - the linear-interpolation crossing between two samples.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import savgol_filter

from .errors import NotApplicable

#: Relative noise below which a response is treated as noise-free (pure interpolation).
NOISE_FREE = 1e-7


def noise_sigma(y: np.ndarray) -> float:
    """Noise standard deviation from the median absolute fourth difference.

    A smooth response has near-zero fourth differences (a sampled lag gives about
    y^(4) dt^4); white noise of variance s^2 gives fourth differences of variance 70 s^2
    (1+16+36+16+1); the median makes steps and spikes harmless. Second differences would
    read the curvature of a smooth, finely sampled response as noise.
    """
    if y.size < 9:
        return 0.0
    d4 = np.diff(y, 4)
    return float(1.4826 * np.median(np.abs(d4 - np.median(d4))) / math.sqrt(70.0))


def smooth(h: np.ndarray, sigma: float, frac: float = 0.02) -> np.ndarray:
    """Savitzky-Golay smoothing (polyorder 2) over ~``frac`` of the window, only if noisy."""
    if sigma <= NOISE_FREE or h.size < 7:
        return h
    w = max(5, int(frac * h.size) | 1)
    w = min(w, (h.size - 1) | 1 if h.size % 2 == 0 else h.size)
    if w < 5:
        return h
    return savgol_filter(h, w, 2)


def crossing_time(tau: np.ndarray, h: np.ndarray, level: float, sigma: float = 0.0, *,
                  start: int = 0, falling: bool = False, name: str = "") -> float:
    """First time at or after index ``start`` where ``h`` reaches ``level``.

    Rising by default (``h >= level``); ``falling=True`` looks for ``h <= level``.
    Raises :class:`NotApplicable` when the level is never reached in the window.
    """
    hs = smooth(h, sigma)
    sgn = -1.0 if falling else 1.0
    above = sgn * (hs[start:] - level) >= 0
    if not above.any():
        label = name or f"{level:.1%}"
        raise NotApplicable(f"the response never reaches {label} of its change in the window")
    i = start + int(np.argmax(above))
    if i == 0:
        return float(tau[0])
    t_c = interp_cross(tau[i - 1], tau[i], hs[i - 1], hs[i], level)
    if sigma <= NOISE_FREE:
        return t_c
    return _refine_crossing(tau, h, hs, i, t_c, level, sigma)


def value_at(tau: np.ndarray, h: np.ndarray, t: float, sigma: float = 0.0,
             half: float | None = None) -> float:
    """The response ``h`` at time ``t`` (read off the graph).

    Noise-free: linear interpolation. Noisy: the centre value of a least-squares
    parabola through the raw samples in a symmetric window around ``t`` (half-width
    ``half``, by default where the smoothed response changes by about +-0.15); a
    symmetric window makes the reading unbiased up to the quartic term of the response.
    """
    if sigma <= NOISE_FREE or h.size < 7:
        return float(np.interp(t, tau, h))
    dt = float(tau[1] - tau[0])
    if half is None:
        hs = smooth(h, sigma)
        slope = abs(float(np.interp(t, tau, np.gradient(hs, tau))))
        half = 0.15 / slope if slope > 0 else 10 * dt
        half = max(half, 5 * dt)
    half = min(half, t - float(tau[0]), float(tau[-1]) - t)
    sel = np.abs(tau - t) <= half
    if sel.sum() < 5:
        return float(np.interp(t, tau, smooth(h, sigma)))
    c2, c1, c0 = np.polyfit(tau[sel] - t, h[sel], 2)
    return float(c0)


def interp_cross(t1, t2, h1, h2, level) -> float:
    if h2 == h1:
        return float(t2)
    return float(t1 + (level - h1) * (t2 - t1) / (h2 - h1))


def _refine_crossing(tau, h, hs, i, t_c, level, sigma) -> float:
    """Local quadratic fit of the raw samples around a preliminary crossing."""
    slope = np.gradient(hs, tau)[i]
    if not np.isfinite(slope) or slope == 0:
        return t_c
    # half-width: enough samples to beat the noise, short enough to stay near-quadratic
    half = min(max(0.08 / abs(slope), 3.5 * (tau[1] - tau[0])), t_c - tau[0]) if i > 0 else 0
    sel = np.abs(tau - t_c) <= half
    if sel.sum() < 5:
        return t_c
    x = tau[sel] - t_c
    c2, c1, c0 = np.polyfit(x, h[sel], 2)
    roots = np.roots([c2, c1, c0 - level])
    roots = roots[np.isreal(roots)].real
    roots = roots[np.abs(roots) <= half]
    return float(t_c + roots[np.argmin(np.abs(roots))]) if roots.size else t_c


def extremum(tau: np.ndarray, h: np.ndarray, lo: int, hi: int, sigma: float,
             *, kind: str = "max") -> tuple[float, float, int]:
    """Peak (``kind="max"``) or valley of ``h`` in samples ``[lo, hi)``: ``(t, h, index)``.

    Noise-free: the vertex of the parabola through the extreme sample and its neighbours.
    Noisy: the vertex of a least-squares parabola over the samples within ~10 % of the
    oscillation period around the smoothed extreme.
    """
    hs = smooth(h, sigma)
    seg = hs[lo:hi]
    if seg.size == 0:
        raise NotApplicable("no samples where an extremum was expected")
    j = lo + int(np.argmax(seg) if kind == "max" else np.argmin(seg))
    if sigma <= NOISE_FREE:
        if 0 < j < h.size - 1:
            x = tau[j - 1 : j + 2] - tau[j]
            c2, c1, c0 = np.polyfit(x, h[j - 1 : j + 2], 2)
            if c2 != 0:
                xv = -c1 / (2 * c2)
                if abs(xv) <= x[-1]:
                    return float(tau[j] + xv), float(c0 - c1 * c1 / (4 * c2)), j
        return float(tau[j]), float(h[j]), j
    half = max(0.1 * (tau[hi - 1] - tau[lo]), 3.5 * (tau[1] - tau[0]))
    sel = np.abs(tau - tau[j]) <= half
    if sel.sum() < 5:
        return float(tau[j]), float(hs[j]), j
    x = tau[sel] - tau[j]
    c2, c1, c0 = np.polyfit(x, h[sel], 2)
    if c2 == 0 or (kind == "max") != (c2 < 0):
        return float(tau[j]), float(hs[j]), j
    xv = float(np.clip(-c1 / (2 * c2), -half, half))
    return float(tau[j] + xv), float(c2 * xv * xv + c1 * xv + c0), j
