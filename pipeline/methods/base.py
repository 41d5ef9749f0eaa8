"""Event-level readings shared by the methods: the normalised response and the dead time.

The array-level toolbox (noise, smoothing, crossings, extrema) is :mod:`pipeline.signal`;
here it is applied to an :class:`~pipeline.events.EventData`:

* :func:`normalised` - time since t0, fractional response and its noise level;
* :func:`band_exit_time` - seed 001 "Time delay": when the output leaves its noise band
  (ERRATA [S1] 14: the first exit of a +-max(1 %, 4 sigma) band);
* :func:`clip_delay` - a negative computed delay becomes 0, recorded as ``delay_computed``
  and ``delay_clipped`` in every method's diagnostics.
"""

from __future__ import annotations

import numpy as np

from ..errors import NotApplicable
from ..events import EventData
from ..signal import interp_cross, smooth


def normalised(ev: EventData) -> tuple[np.ndarray, np.ndarray, float]:
    """``(tau, h, sigma_h)``: time since t0, fractional response (y - y0)/(y_ss - y0) and
    its noise level; a step with no output change is not applicable."""
    tau, dy = ev.after()
    if ev.dy == 0 or not np.isfinite(ev.dy) or abs(ev.dy) <= 3 * ev.noise:
        raise NotApplicable("the output did not change measurably (|y_ss - y0| <= 3 sigma)")
    return tau, dy / ev.dy, ev.noise / abs(ev.dy)


def band_exit_time(ev: EventData, band_rel: float = 0.01, band_sigma: float = 4.0
                   ) -> tuple[float, float]:
    """``(time since t0, band as a fraction of the change)`` when the output first leaves
    the band ``y0 +- max(band_rel |dy|, band_sigma sigma)`` (seed 001 "Time delay")."""
    tau, h, sigma = normalised(ev)
    frac = max(band_rel, band_sigma * sigma)
    if frac >= 0.5:
        raise NotApplicable(f"the noise band (+-{frac:.0%} of the change) is too wide to see "
                            "where the output starts to move")
    hs = smooth(h, sigma)
    out = np.abs(hs) > frac
    if not out.any():
        raise NotApplicable("the output never leaves its noise band")
    i = int(np.argmax(out))
    if i == 0:
        return 0.0, frac
    return interp_cross(tau[i - 1], tau[i], abs(hs[i - 1]), abs(hs[i]), frac), frac


def clip_delay(raw: float) -> tuple[float, dict]:
    """``(delay, diagnostics)``: a negative computed dead time becomes 0, the time
    constants kept (ERRATA [S2] 6); the raw value is always recorded under one key for
    every method, ``delay_computed``, with ``delay_clipped`` true when it was negative, so
    grading can flag a clipped delay."""
    raw = float(raw)
    return max(0.0, raw), {"delay_computed": raw, "delay_clipped": raw < 0}
