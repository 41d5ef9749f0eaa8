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
#: The share of the window the peak is read over where the record is noisy.
PEAK_SMOOTHING = 0.02
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
    # the peak and the undershoot of the response, not of the noise on it: read off a
    # Savitzky-Golay smoothing over 2 % of the window where the record is noisy
    curve = smooth(dy, noise_sigma(dy), PEAK_SMOOTHING)
    k = int(np.argmax(curve))
    dyp = float(curve[k])
    rest = curve[k:]
    # the first undershoot: the minimum before the response rises again past its mean
    turn = np.flatnonzero(np.diff(rest) > 0)
    dyu = float(rest[: turn[0] + 1].min()) if turn.size and turn[0] > 0 else None
    tail = max(dy.size // 10, 1)
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


def setpoint_overshoot_pi(test: OvershootTest, detune: float = 1.0) -> Controller:
    """PI settings (ideal form) from :func:`read_setpoint_step`'s reading, eqs. (15)-(17) of the
    module docstring; ``detune`` is the paper's ``F``. Raises ValueError for an overshoot
    outside :data:`OVERSHOOT_RANGE` or an offset ratio of 1 or more (the loop has integral
    action already)."""
    d, b = test.overshoot, test.offset_ratio
    lo, hi = OVERSHOOT_RANGE
    if not lo <= d <= hi:
        raise ValueError(f"the overshoot is {d:.0%}: the method's correlation holds for "
                         f"{lo:.0%}-{hi:.0%} (about 30 % is best); repeat the step with Kc0 "
                         f"{'raised' if d < lo else 'lowered'}")
    if not 0 < b < 1:
        raise ValueError(f"the steady change is {b:.3g} of the setpoint's: a P loop leaves "
                         "an offset (below 1); this loop does not")
    a = 1.152 * d * d - 1.607 * d + 1.0
    kc = test.kc0 * a / detune
    ti = min(0.86 * a * abs(b / (1.0 - b)) * test.tp, 2.44 * test.tp * detune)
    return Controller.ideal(kc, ti)
