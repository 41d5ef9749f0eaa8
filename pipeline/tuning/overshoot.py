"""The setpoint overshoot method: PI settings from one closed-loop setpoint step under
proportional control, without a model (M. Shamsuzzoha, S. Skogestad, "The setpoint
overshoot method: A simple and fast closed-loop approach for PI tuning", Journal of
Process Control 20(10):1220-1234, 2010).

The experiment: a P controller of gain ``Kc0`` (tuned so the loop overshoots by about
30 %, within 10-60 %), a setpoint step ``dys``. Read from the response (deviations from
the output before the step): the peak ``dyp`` at ``tp`` after the step, the steady
change ``dyinf`` (or, when the loop was not left to settle, ``0.45 (dyp + dyu)`` with
``dyu`` the first undershoot after the peak, the paper's eq. (18)), the overshoot
``D = (dyp - dyinf) / dyinf`` and the steady-state ratio ``b = dyinf / dys`` (below 1: a
P loop leaves an offset). Then, with the detuning factor ``F`` (1: the paper's default,
settings close to SIMC's with ``tau_c = theta``; larger is slower and more robust)::

    A = 1.152 D^2 - 1.607 D + 1.0                    (eq. 15)
    Kc = Kc0 A / F                                   (eq. 16)
    Ti = min(0.86 A |b / (1 - b)| tp, 2.44 tp F)     (eq. 17)

On first-order-plus-dead-time plants with ``tau / theta`` from 0.5 to 20 the paper
reports these within about -2..+17 % of SIMC's Kc and -5..+27 % of its Ti
(``tests/test_setpoint_overshoot.py`` checks the sweep against SIMC on simulated loops).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..signal import noise_sigma, smooth
from .controller import Controller

#: The paper's estimate of the steady change from the peak and the first undershoot
#: when the loop is not left to settle (eq. 18).
SETTLE_FROM_SWING = 0.45
#: The share of the rise (samples to the first crossing of the steady level) the peak
#: and the undershoot are smoothed over where the record is noisy.
PEAK_SMOOTHING = 0.2
#: The response has turned up from its undershoot once it is this many noise standard
#: deviations above its lowest point since the peak (a wiggle of the noise is not a turn).
BAND_SIGMAS = 3.0
#: The overshoots the correlation was derived for (the paper's recommended test range).
OVERSHOOT_RANGE = (0.1, 0.6)


@dataclass(frozen=True)
class OvershootTest:
    """What one closed-loop setpoint step under P control (gain ``kc0``) shows: the
    setpoint change ``dys``, the peak change ``dyp`` at ``tp`` after the step, the first
    undershoot ``dyu`` after the peak (None if the window ends first) and the steady
    change ``dyinf``, all in the output's units from its level before the step."""

    kc0: float
    dys: float
    dyp: float
    tp: float
    dyu: float | None
    dyinf: float

    @property
    def overshoot(self) -> float:
        """``D = (dyp - dyinf) / dyinf``."""
        return (self.dyp - self.dyinf) / self.dyinf

    @property
    def offset_ratio(self) -> float:
        """``b = dyinf / dys``."""
        return self.dyinf / self.dys


def read_setpoint_step(t, y, t_step: float, dys: float, kc0: float, *, settled: bool = True
              ) -> OvershootTest:
    """The :class:`OvershootTest` of the response ``t, y`` to a setpoint step of ``dys`` at
    ``t_step`` under a P controller of gain ``kc0``: the output's level before the step
    is the mean of the samples before it; the peak is the largest change in the
    direction of ``dys`` (on a noisy record, of the smoothed response); the steady change
    the mean of the last tenth of the window (``settled``), else the paper's
    ``0.45 (dyp + dyu)``. Raises ValueError when the
    record shows no step, no overshoot or no undershoot where one is needed."""
    t, y = np.asarray(t, np.float64), np.asarray(y, np.float64)
    before, after = t < t_step, t >= t_step
    if not before.any() or np.count_nonzero(after) < 10 or dys == 0:
        raise ValueError("a setpoint step needs samples before it and at least 10 after")
    sign = math.copysign(1.0, dys)
    dy = sign * (y[after] - float(np.mean(y[before])))
    ta = t[after] - t_step
    tail = max(dy.size // 10, 1)
    # the peak and the undershoot of the response, not of the noise on it: read off a
    # Savitzky-Golay smoothing where the record is noisy, over a share of the rise (the
    # samples until the output first reaches its last tenth's level), not of the window:
    # a long settled tail must not flatten the peak
    sigma = noise_sigma(dy)
    reached = np.flatnonzero(dy >= float(np.mean(dy[-tail:])))
    rise = int(reached[0]) if reached.size else dy.size
    curve = smooth(dy, sigma, min(PEAK_SMOOTHING * rise / dy.size, 0.5))
    k = int(np.argmax(curve))
    dyp = float(curve[k])
    dyu = _undershoot(curve[k:], BAND_SIGMAS * sigma)
    if k >= dy.size - tail:
        raise ValueError("the P loop's setpoint response does not overshoot (it peaks at "
                         "the window's end): raise Kc0 until it overshoots by 10-60 %")
    if settled:
        dyinf = float(np.mean(dy[-tail:]))
    elif dyu is None:
        raise ValueError("the response has no undershoot after its peak within the window:"
                         " the steady change cannot be estimated from the swing")
    else:
        dyinf = SETTLE_FROM_SWING * (dyp + dyu)
    if not dyinf > 0 or not dyp > dyinf:
        raise ValueError("the P loop's setpoint response does not overshoot: raise Kc0 "
                         "until it overshoots by 10-60 %")
    return OvershootTest(float(kc0), abs(float(dys)), dyp, float(ta[k]), dyu, dyinf)


def _undershoot(after_peak: np.ndarray, band: float) -> float | None:
    """The first undershoot of a response from its peak on: the lowest point before the
    response turns up by more than ``band`` (None when the window ends before it does)."""
    low = np.minimum.accumulate(after_peak)
    up = np.flatnonzero(after_peak > low + max(band, 0.0))
    if not up.size or up[0] == 0:
        return None
    return float(low[up[0]])


def setpoint_overshoot_pi(test: OvershootTest, detune: float = 1.0) -> Controller:
    """PI settings (ideal form) from :func:`read_setpoint_step`'s reading, eqs. (15)-(17) of the
    module docstring; ``detune`` is the paper's ``F``. Raises ValueError for an overshoot
    outside :data:`OVERSHOOT_RANGE` or an output that did not follow the setpoint."""
    d, b = test.overshoot, test.offset_ratio
    lo, hi = OVERSHOOT_RANGE
    if not lo <= d <= hi:
        raise ValueError(f"the overshoot is {d:.0%}: the method's correlation holds for "
                         f"{lo:.0%}-{hi:.0%} (about 30 % is best); repeat the step with Kc0 "
                         f"{'raised' if d < lo else 'lowered'}")
    if not b > 0:
        raise ValueError(f"the steady change is {b:.3g} of the setpoint's: the output did "
                         "not follow the setpoint")
    a = 1.152 * d * d - 1.607 * d + 1.0
    kc = test.kc0 * a / detune
    # an integrating process leaves no offset (b = 1): the first term is unbounded and
    # the second sets Ti, as it does for any b near 1
    first = 0.86 * a * abs(b / (1.0 - b)) * test.tp if b != 1 else math.inf
    ti = min(first, 2.44 * test.tp * detune)
    return Controller.ideal(kc, ti)
