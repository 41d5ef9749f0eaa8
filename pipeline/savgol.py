"""Savitzky-Golay filtering (polyorder 2) in ``O(N log w)`` for long windows.

:func:`pipeline.signal.smooth` smooths over 2 % of an event's window, so a direct
convolution (``N w``) made the smoothing of a long event quadratic in its length
(issue 14: the methods' cost per event grew faster than the window).
"""

from __future__ import annotations

import numpy as np
from scipy.signal import oaconvolve, savgol_coeffs, savgol_filter

#: From this many taps on, :func:`savgol` convolves by overlap-add FFT instead of directly.
#: A direct convolution costs ``N w`` and ``w`` grows with the window (2 % of it), so the
#: smoothing of a long event was quadratic in its length; overlap-add costs about
#: ``N log w``. Measured (``benchmarks/methods_speed.py --crossover``, BENCHMARKS.md):
#: about equal below ~100 taps, 3x faster at 201 taps and 7-11x at 1,201 taps; the two
#: differ by rounding (below 6e-15 on a unit response). 201 taps (2 % of 10,000 samples)
#: keeps the direct path, and results identical to the bit, for every event window under
#: 10,000 samples (DaISy's and nearly all of the test suite's events).
SAVGOL_FFT_TAPS = 201


def savgol(h: np.ndarray, window: int, deriv: int = 0, delta: float = 1.0) -> np.ndarray:
    """``scipy.signal.savgol_filter(h, window, 2, deriv, delta)`` (mode "interp"), in
    ``O(N log window)`` for long windows.

    The interior is the convolution of ``h`` with :func:`scipy.signal.savgol_coeffs`
    (:func:`scipy.signal.oaconvolve`); the first and last ``window // 2`` values are, as
    in ``savgol_filter``'s mode "interp", the quadratic least-squares fits of the first
    and last ``window`` samples (:func:`numpy.polyfit`) and their derivative, evaluated
    there (``savgol_filter`` on the edge samples alone would convolve them too, ``w^2``)."""
    if window < SAVGOL_FFT_TAPS or h.size < 2 * window:
        return savgol_filter(h, window, 2, deriv=deriv, delta=delta)
    out = oaconvolve(h, savgol_coeffs(window, 2, deriv=deriv, delta=delta, use="conv"),
                     mode="same")
    half = window // 2
    k = np.arange(window, dtype=np.float64)
    for edge, at in ((slice(0, window), slice(0, half)),
                     (slice(h.size - window, h.size), slice(window - half, window))):
        p = np.polyder(np.polyfit(k, h[edge], 2), deriv)
        out[edge][at] = np.polyval(p, k[at]) / delta**deriv
    return out
