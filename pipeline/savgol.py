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
#: ``N log w``. Measured (benchmarks/methods_speed.py and the crossover in BENCHMARKS.md):
#: equal at about 128-200 taps, 5x faster at 1,201 taps on 60,000 samples; the two differ
#: by rounding (below 3e-15 on a unit response). Below the threshold (every event window
#: under 10,000 samples) the direct path is kept, results identical to the bit.
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
