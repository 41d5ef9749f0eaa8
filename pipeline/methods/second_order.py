"""Second-order underdamped step method: overshoot and period (seed 001)."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from ..errors import NotApplicable
from ..events import EventData
from ..models import ProcessModel
from ..responses import second_order_step
from .base import band_exit_time, clip_delay, normalised
from .prepared import Response
from .registry import MethodResult, register


def zeta_from_overshoot(M: float) -> float:
    """Seed 001: solve M = exp(-zeta pi / sqrt(1 - zeta^2)) for zeta (natural log)."""
    lm = math.log(M)
    return -lm / math.sqrt(math.pi**2 + lm * lm)


def oscillation(resp: Response, level: float = 1.0) -> dict:
    """First peak, first valley and second peak of the response oscillating about ``level``.

    Returns times and values ``t1, h1, t2, h2, t3, h3`` (``t3`` / ``h3`` may be None).
    Raises :class:`NotApplicable` when there is no overshoot above the noise.
    """
    h, hs, sigma = resp.h, resp.hs, resp.sigma
    thr = max(3 * sigma, 1e-4)  # zeta = 0.9 still overshoots by 1.5e-3
    up = np.flatnonzero(hs > level + thr)
    if up.size == 0:
        raise NotApplicable("no overshoot: the response never rises above its steady state")
    a = int(up[0])
    down = np.flatnonzero(hs[a:] < level)
    if down.size == 0:
        raise NotApplicable("no overshoot: the response rises above its final average but "
                            "never comes back below it (still creeping, not oscillating)")
    b = a + int(down[0])
    t1, h1, _ = resp.extremum(a, b, kind="max")
    back = np.flatnonzero(hs[b:] > level)
    c = b + int(back[0]) if back.size else hs.size
    t2, h2, _ = resp.extremum(b, c, kind="min")
    out = {"t1": t1, "h1": h1, "t2": t2, "h2": h2, "t3": None, "h3": None}
    if back.size:
        nxt = np.flatnonzero(hs[c:] < level)
        d = c + int(nxt[0]) if nxt.size else None
        if d is not None and d - c >= 3 and h[c:d].max() - level > 3 * sigma:
            out["t3"], out["h3"], _ = resp.extremum(c, d, kind="max")
    return out


@register(id="second_order_overshoot", event="step",
          structures=("second_order",),
          references=("seborg1989", "busoniu"),
          source="seed 001 'Determining the parameters' (overshoot, period), "
                 "'Nonzero initial conditions', 'Time delay'",
          title="Second order, overshoot and period")
def second_order_overshoot(ev: EventData) -> MethodResult:
    """Underdamped second order from a step (seed 001).

    1. ``K = (y_ss - y0)/(u_ss - u0)``.
    2. Overshoot (a) from the first peak ``M = (y(t1) - y_ss)/(y_ss - y0)``; (b) from the
       valley/peak ratio ``M = (y_ss - y(t2))/(y(t1) - y_ss)`` (reported as ``zeta_ratio``).
    3. ``zeta = ln(1/M)/sqrt(pi^2 + ln^2 M)``.
    4. ``T0 = t3 - t1`` (two peaks) or ``2 (t2 - t1)``; ``wn = 2 pi/(T0 sqrt(1 - zeta^2))``.
       The period is read as twice the time between the first two crossings of the steady
       state (the same half period as peak to valley, but not read at flat noisy tops);
       the peak reading is kept as ``period_peaks``.

    Dead time: the output leaves its noise band at ``t_e``; the undelayed model needs
    ``t_b`` to get there, ``delay = t_e - t_b``. Not applicable without an overshoot, or
    when the oscillation is not real (:func:`check_oscillation`).
    """
    resp = normalised(ev)
    tau, sigma = resp.tau, resp.sigma
    K = ev.dy / ev.du
    osc = oscillation(resp)
    M = osc["h1"] - 1.0
    if not 0 < M < 1:
        raise NotApplicable(f"overshoot {M:.3g} outside (0, 1)")
    zeta = zeta_from_overshoot(M)
    M_ratio = (1.0 - osc["h2"]) / (osc["h1"] - 1.0)
    zeta_ratio = zeta_from_overshoot(M_ratio) if 0 < M_ratio < 1 else None
    period_peaks = (osc["t3"] - osc["t1"] if osc["t3"] is not None
                    else 2 * (osc["t2"] - osc["t1"]))
    # The zeros of h - 1 are exactly half a period apart (a delay shifts both); read between
    # many samples they are far less noisy than the flat tops of the peaks.
    c0 = resp.crossing(1.0)
    c1 = resp.crossing(1.0, start=int(np.searchsorted(tau, osc["t1"])), falling=True)
    T0 = 2 * (c1 - c0) if c1 > c0 else period_peaks
    wn = 2 * math.pi / (T0 * math.sqrt(1 - zeta**2))
    t_e, frac = band_exit_time(ev)
    check_oscillation(osc, sigma, T0 / 2, c0 - t_e, step_rise(zeta, T0 / 2, frac))
    t_b = time_to_fraction(zeta, wn, frac)
    delay, ddiag = clip_delay(t_e - t_b)
    diag = {"t0": ev.t0, "t_peak1": ev.t0 + osc["t1"], "y_peak1": ev.y0 + osc["h1"] * ev.dy,
            "t_valley1": ev.t0 + osc["t2"], "y_valley1": ev.y0 + osc["h2"] * ev.dy,
            "t_peak2": ev.t0 + osc["t3"] if osc["t3"] is not None else None,
            "overshoot": M, "overshoot_ratio": M_ratio, "zeta_ratio": zeta_ratio,
            "period": T0, "period_peaks": period_peaks, "t_band_exit": ev.t0 + t_e, **ddiag}
    return MethodResult(
        ProcessModel("second_order", {"K": K, "zeta": zeta, "wn": wn, "delay": delay}), diag)


#: A ring is lightly damped when its valley/peak decay gives a damping ratio below this
#: (or the valley is as deep as the peak, as behind a lag). One overshoot that barely
#: dips below the final value is not a ring: the DC motor of daniw/rt-l overshoots by
#: 1.7 % and its valley gives zeta 0.61 (valley/peak 0.09); a zeta-0.1 pair behind a 1 s
#: lag overshoots by 9 % with valley/peak 1.08.
LIGHT_DAMPING = 0.5


def light_ring(reading) -> bool:
    """Whether a :func:`second_order_overshoot` reading (a :class:`~pipeline.fit.Fit`)
    found a lightly damped ring: a significant oscillation whose valley/peak decay gives
    a damping ratio below :data:`LIGHT_DAMPING`, or a valley as deep as the peak."""
    if reading is None or not reading.ok:
        return False
    zeta = reading.diagnostics.get("zeta_ratio")
    return zeta is None or zeta < LIGHT_DAMPING


#: Behind a lag the period read from the crossings and from the two peaks must agree
#: within this share (:func:`ring_behind_lag`).
PERIOD_AGREEMENT = 0.3


def ring_behind_lag(ev: EventData) -> tuple[float, float] | None:
    """A lightly damped ring the rise check of :func:`check_oscillation` refuses because
    a lag in front of it slows the rise (Åström & Hägglund's oscillatory plant: a 1 s lag
    before a pair of 2.1 s period rises in 2.9 s where the pair alone would need 0.56 s):
    ``(zeta, period)`` or None. The overshoot and the valley pass the significance test
    of :func:`check_oscillation`, a second peak stands 3 noise sigmas above the final
    value (:func:`oscillation`), and the period twice the time between the first two
    crossings agrees with the time between the peaks within :data:`PERIOD_AGREEMENT` (a
    wiggle of noise riding on a slow rise has no second peak one period on). The damping
    is read from the decay of the two peaks, ``r = (h3 - 1)/(h1 - 1) = exp(-2 pi zeta/
    sqrt(1 - zeta^2))`` (the lag no longer weighs on it one period on); it must be below
    :data:`LIGHT_DAMPING`."""
    if ev.kind != "step":
        return None
    try:
        resp = normalised(ev)
        osc = oscillation(resp)
    except NotApplicable:
        return None
    c0 = resp.crossing(1.0)
    c1 = resp.crossing(1.0, start=int(np.searchsorted(resp.tau, osc["t1"])), falling=True)
    if osc["t3"] is None or not c1 > c0:
        return None
    period, peaks = 2.0 * (c1 - c0), osc["t3"] - osc["t1"]
    try:
        check_oscillation(osc, resp.sigma, period / 2.0)
    except NotApplicable:
        return None
    if abs(peaks / period - 1.0) > PERIOD_AGREEMENT:
        return None
    r = (osc["h3"] - 1.0) / (osc["h1"] - 1.0)
    if not 0.0 < r < 1.0:
        return None
    log_r = math.log(r)
    zeta = -log_r / math.sqrt(4.0 * math.pi**2 + log_r**2)
    return (zeta, period) if zeta < LIGHT_DAMPING else None


#: Significance of the overshoot and of the valley, in standard deviations of a reading
#: (see :func:`check_oscillation`).
Z_PEAK = 3.0
Z_VALLEY = 2.0
#: The rise to the first crossing must agree with the period's prediction within this factor.
RISE_FACTOR = 2.0


def check_oscillation(osc: dict, sigma: float, half_period: float, rise: float | None = None,
                      predicted: float | None = None, level: float = 1.0) -> None:
    """Refuse an oscillation that is not there (not applicable, with the numbers).

    1. Significance against the noise. The overshoot ``h1 - level`` and the valley depth
       ``level - h2`` are differences of two readings of the noisy response (the extremum,
       a local fit whose error is up to the marginal noise ``sigma`` when the noise is
       coloured and averages poorly, and the final value), so their standard deviation is
       up to ``sqrt(2) sigma``. The overshoot must exceed ``Z_PEAK = 3`` and the valley
       ``Z_VALLEY = 2`` such standard deviations: for Gaussian noise a one-sided false
       alarm below 0.14 % and 2.3 %, and both must hold. ``sigma`` is the marginal noise
       (:func:`pipeline.signal.noise_estimate`): for coloured noise the high-frequency
       reading is several times too small (seed 001's 3-sigma test, ERRATA [S1] 14).
    2. The rise agrees with the period: ``rise`` (measured, from where the output starts
       to move to the first crossing of ``level``) against ``predicted``, what an
       oscillation of half period ``P/2`` needs (:func:`step_rise`; an impulse response
       crosses its baseline after one half period). A measured rise more than
       ``RISE_FACTOR = 2`` times longer or shorter is a "period" of noise riding on a slow
       response (e.g. a 20 s wiggle after a 500 s rise), not an oscillation of the
       process. ``rise = None`` skips the check.
    """
    s = math.sqrt(2.0) * sigma
    over, valley = osc["h1"] - level, level - osc["h2"]
    if not over > Z_PEAK * s:
        raise NotApplicable(f"the overshoot ({over:.2%} of the change) is not significant "
                            f"against the noise (needs > {Z_PEAK:g} x {s:.2%})")
    if not valley > Z_VALLEY * s:
        raise NotApplicable(f"the valley after the peak ({valley:.2%} of the change) is not "
                            f"significant against the noise (needs > {Z_VALLEY:g} x {s:.2%}):"
                            " no oscillation")
    if rise is None or predicted is None:
        return
    if not (predicted > 0 and 1.0 / RISE_FACTOR <= rise / predicted <= RISE_FACTOR):
        raise NotApplicable(
            f"the period ({2 * half_period:.4g} s) is inconsistent with the response's own "
            f"rise: the first crossing comes {rise:.4g} s after the output starts to move, "
            f"an oscillation of that period would take {predicted:.4g} s")


def step_rise(zeta: float, half_period: float, frac: float) -> float:
    """Time from leaving the band ``frac`` to the first crossing of the final value, for
    the underdamped step response of damping ``zeta`` and half period ``P/2 = pi/wd``:
    the response crosses 1 at ``(pi - acos zeta)/wd`` (seed 000 section II: ``y = 1`` where
    ``sin(wd t + acos zeta) = 0``), less its own time to the band."""
    wn = math.pi / (half_period * math.sqrt(1 - zeta**2))
    t_b = time_to_fraction(zeta, wn, frac) if frac > 0 else 0.0
    return (1.0 - math.acos(zeta) / math.pi) * half_period - t_b


def time_to_fraction(zeta: float, wn: float, frac: float) -> float:
    """Time the undelayed unit second-order response needs to reach ``frac`` (< first peak)."""
    f = lambda t: second_order_step(np.array([t]), zeta, wn)[0] - frac  # noqa: E731
    hi = math.pi / (wn * math.sqrt(1 - zeta**2))
    return brentq(f, 0.0, hi) if f(hi) > 0 else 0.0
