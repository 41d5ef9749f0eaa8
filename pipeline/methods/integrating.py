"""Integrating processes: the final-ramp asymptote after a step, the level shift after a
pulse (Åström & Hägglund, "Advanced PID Control", ISA 2006: the integrating model
``K e^{-Ls}/s`` read off a step response's ramp, and the integrator with a lag).

Both methods read the event's response ``r = y - y0 - drift (t - t0)`` (deviation from
the baseline line; :mod:`pipeline.segmentation` step 6), for ``K e^{-L s}/(s (T s + 1))``:

    step du:  r(tau) = K du [(tau - L) - T (1 - e^{-(tau - L)/T})]   (tau > L),

whose asymptote ``K du (tau - (T + L))`` crosses the initial level at ``tau = T + L``,
and which lies above it by ``K du T e^{-(tau - L)/T}``: ``K du T/e`` at the intercept.

    pulse of area A:  r -> K A,   integral_0^inf (K A - r) dtau = K A (t_c + T + L),

with ``t_c`` the centroid of the pulse (first moment of the lagged, delayed pulse).
A lag the data do not resolve (a likelihood-ratio test against ``T = 0``, or shorter than
one sample) gives the pure integrator ``K e^{-L s}/s`` with ``L = T + L``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize_scalar

from ..errors import NotApplicable
from ..events import EventData
from ..models import ProcessModel
from ..responses import integrator_lag_step
from ..signal import smooth
from ..simulation import simulate
from .base import input_change
from .registry import MethodResult, register


def _response(ev: EventData) -> tuple[np.ndarray, np.ndarray]:
    """Time since t0 and the response less the baseline line."""
    i = ev.i0
    tau = ev.t[i:] - ev.t0
    if tau.size < 20:
        raise NotApplicable("fewer than 20 samples after t0")
    return tau, ev.y[i:] - ev.y0 - ev.drift * tau


def _asymptote(tau: np.ndarray, r: np.ndarray, sel: np.ndarray, gap: np.ndarray
               ) -> tuple[float, float, float]:
    """``(slope, intercept time, standard error of the slope)`` of the straight line the
    response ends on, fitted over ``sel`` after removing the lag's remaining ``gap``
    (``s T e^{-(tau - L)/T}`` of the current estimate)."""
    x, y = tau[sel], r[sel] - gap[sel]
    s, c = np.polyfit(x, y, 1)
    resid = y - (s * x + c)
    se = float(np.std(resid) / math.sqrt(np.sum((x - x.mean()) ** 2)))
    return float(s), float(-c / s), se


def _lag_fit(cost, upper: float, sigma: float) -> tuple[float, float]:
    """``(T, chi2)``: the lag in ``[0, upper]`` that minimises ``cost(T)`` (a sum of
    squared residuals) and the drop of the cost from ``T = 0`` in units of the noise
    variance (a likelihood-ratio statistic; above :data:`LAG_CHI2` the lag is resolved)."""
    res = minimize_scalar(cost, bounds=(0.0, upper), method="bounded",
                          options={"xatol": 1e-6 * max(upper, 1e-12)})
    T = float(res.x)
    drop = cost(0.0) - float(res.fun)
    return T, drop / sigma**2 if sigma > 0 else (math.inf if drop > 0 else 0.0)


#: A lag is kept when it lowers the squared error by more than 9 noise variances (the
#: likelihood-ratio test of T = 0 at 3 sigma); otherwise the model is a pure integrator.
LAG_CHI2 = 9.0
#: The asymptote and the bend are read alternately until the dead time stops moving.
MAX_PASSES = 20


def _integrator(K: float, T: float, lag: float, chi2: float, dt: float) -> ProcessModel:
    """``K e^{-(lag - T) s}/(s (T s+1))``, or the pure integrator ``K e^{-lag s}/s`` when
    the lag is not resolved (``chi2`` at most :data:`LAG_CHI2`, or ``T`` within a sample)."""
    if chi2 <= LAG_CHI2 or T <= dt:
        return ProcessModel("integrator", {"K": K, "delay": lag})
    return ProcessModel("integrator_lag", {"K": K, "T": T, "delay": lag - T})


@register(id="integrator_asymptote", event="step", structures=("integrator_lag", "integrator"),
          references=("astrom2006",),
          source="Åström & Hägglund 2006 (integrating model K_v e^{-sL}/s from the "
                 "asymptote of the step response); module docstring",
          title="Integrator, final-ramp asymptote")
def integrator_asymptote(ev: EventData) -> MethodResult:
    """``K e^{-L s}/(s (T s + 1))`` (or ``K e^{-L s}/s``) from the ramp a step leaves.

    1. The asymptote: a straight line fitted to the last half of the window, where
       segmentation found the slope steady, and from ``L + 3 T`` on once a lag is known,
       after subtracting the lag's remaining gap (passes with step 2 until the dead time
       stops moving). ``K = slope / du`` (output unit per input unit per second) and the
       line's intercept with the initial level is ``T + L`` (Åström & Hägglund).
    2. ``T`` is the lag of the bend between the initial level and the asymptote: the one
       parameter that, with ``L = (T + L) - T``, fits the response up to the asymptote
       region in the least-squares sense. The classic reading, the gap between curve and
       asymptote at the intercept time (``K du T/e``), is in the diagnostics
       (``T_gap``); it reads one noisy point where the bend fit uses all of them.
    3. The lag is kept when it lowers the squared error of the bend by more than
       :data:`LAG_CHI2` noise variances (``lag_chi2``); otherwise the model is the pure
       integrator with ``delay = T + L``.

    Domain: a step whose window ends on a steady ramp (``response == "ramp"``);
    a settling (self-regulating) response is not applicable, as is a ramp whose asymptote
    does not cross the initial level between t0 (within a sample) and the middle of the
    window.
    """
    if ev.response != "ramp":
        raise NotApplicable(f"the output does not end on a steady ramp (response "
                            f"{ev.response!r}): not an integrating process")
    input_change(ev)
    tau, r = _response(ev)
    half, dt = float(tau[tau.size // 2]), float(np.median(np.diff(tau)))
    T, L, start, gap = 0.0, 0.0, half, np.zeros_like(r)
    for _ in range(MAX_PASSES):
        s, intercept, se = _asymptote(tau, r, tau >= start, gap)
        if not -dt <= intercept < half:
            raise NotApplicable(f"the ramp's asymptote crosses the initial level at "
                                f"{intercept:.3g} s after t0, not inside the first half "
                                "of the window")
        intercept = max(intercept, 0.0)  # within a sample of t0: no dead time, no lag
        bend = tau <= max(start, intercept + 3 * T)
        T, chi2 = _lag_fit(_bend_cost(tau[bend], r[bend], s, intercept), intercept, ev.noise)
        moved = abs(intercept - T - L) if L else math.inf
        L = intercept - T
        start = min(half, L + 3 * T)  # beyond 3 T the gap is 5 % of T and corrected
        gap = s * T * np.exp(-np.maximum(tau - L, 0.0) / T) if T > 0 else np.zeros_like(r)
        if moved <= 1e-9 * intercept:
            break
    r_i = float(np.interp(intercept, tau, smooth(r, ev.noise / max(abs(r[-1]), 1e-300))))
    K = s / ev.du
    diag = {"t0": ev.t0, "slope": s + ev.drift, "drift": ev.drift, "slope_se": se,
            "t_intercept": ev.t0 + intercept, "y_intercept": ev.y0 + ev.drift * intercept,
            "T_plus_delay": intercept, "T_gap": math.e * r_i / s, "lag_chi2": chi2}
    return MethodResult(_integrator(K, T, intercept, chi2, dt), diag)


def _bend_cost(tau: np.ndarray, r: np.ndarray, s: float, intercept: float):
    """Squared error of the bend onto the asymptote ``s (tau - intercept)`` for a lag T
    (``L = intercept - T``)."""

    def cost(T: float) -> float:
        model = s * integrator_lag_step(np.maximum(tau - (intercept - T), 0.0), T)
        return float(np.sum((r - model) ** 2))

    return cost


@register(id="integrator_pulse", event="impulse", structures=("integrator_lag", "integrator"),
          references=("astrom2006",),
          source="final value and first moment of a pulse response on K e^{-Ls}/(s(Ts+1)); "
                 "module docstring",
          title="Integrator, level shift over pulse area")
def integrator_pulse(ev: EventData) -> MethodResult:
    """``K e^{-L s}/(s (T s + 1))`` (or ``K e^{-L s}/s``) from a pulse that moves the
    output to a new level.

    1. ``K = (y_ss - y0)/A``: the level change over the pulse area (final value theorem
       of ``K/s`` driven by a pulse of area ``A``; any pulse shape and width). The level
       is the mean over the last half of the window, where segmentation found it steady,
       corrected for what the lag of the current model has still to cover there.
    2. ``T + L = M - t_c``: ``M = integral (y_ss - y) dt / (y_ss - y0)`` is the first
       moment of the response (the area between the new level and the response; the
       lag's tail beyond the window added from the model), ``t_c`` that of the pulse.
    3. The split: the lag ``T`` (``L = (T + L) - T``) whose model, driven by the measured
       pulse, fits the response in the least-squares sense (one parameter), kept when
       it is resolved (``lag_chi2`` above :data:`LAG_CHI2`). Steps 1-3 are repeated three
       times, each with the model of the pass before.

    Domain: an impulse event whose output moved to a new level and stayed there
    (``response == "level_shift"``, settled); a response that returns to its baseline
    (a self-regulating process) or is still moving is not applicable.
    """
    if ev.response != "level_shift":
        raise NotApplicable(f"the output does not move to a new level and stay there "
                            f"(response {ev.response!r}): not an integrating process")
    if not ev.settled:
        raise NotApplicable("the new level is still moving at the end of the window")
    if ev.area == 0:
        raise NotApplicable("the impulse has no area")
    tau, r = _response(ev)
    t, u_in = ev.t[ev.i0 :], ev.u[ev.i0 :]
    u = u_in - ev.u0
    dt_k = np.diff(tau, append=tau[-1])  # the input is held over each interval (ZOH)
    t_c = float(np.sum((tau + dt_k / 2) * u * dt_k) / np.sum(u * dt_k))
    h, dt = tau.size // 2, float(np.median(np.diff(tau)))
    # noise of the area between level and response: the samples' own, and the level's
    # (the mean of the last half) times the window
    e_moment = ev.noise * (dt * math.sqrt(tau.size) + float(tau[-1]) / math.sqrt(tau.size - h))
    unit = np.ones_like(r)  # the normalised response of the current model (none yet)
    T, chi2 = 0.0, 0.0
    for _ in range(3):
        # the level: the last half's mean, less what the lag has still to cover there
        shift = float(np.mean(r[h:]) / np.mean(unit[h:]))
        gap = shift - r
        M = float(np.sum((gap[1:] + gap[:-1]) * np.diff(tau)) / 2) / shift  # smooth output
        M += T * (1.0 - float(unit[-1]))  # the lag's exponential tail beyond the window
        lag = M - t_c
        if not lag >= -max(dt, 3 * e_moment / abs(shift)):
            raise NotApplicable(f"the response's first moment ({M:.3g} s) comes before "
                                f"the pulse's ({t_c:.3g} s)")
        lag = max(lag, 0.0)  # within its noise of the pulse's: no dead time, no lag
        T, chi2 = _lag_fit(_pulse_cost(t, u_in, ev.u0, r, shift / ev.area, lag), lag,
                           ev.noise)
        unit = simulate(ProcessModel("integrator_lag", {"K": 1.0 / ev.area, "T": T,
                                                        "delay": lag - T}),
                        t, u_in, ev.u0, 0.0)
    K = shift / ev.area
    diag = {"t0": ev.t0, "area": ev.area, "level_shift": shift, "t_centroid": ev.t0 + t_c,
            "first_moment": ev.t0 + M, "T_plus_delay": lag, "lag_chi2": chi2}
    return MethodResult(_integrator(K, T, lag, chi2, dt), diag)


def _pulse_cost(t: np.ndarray, u: np.ndarray, u0: float, r: np.ndarray, K: float,
                lag: float):
    """Squared error of the model ``K e^{-(lag - T) s}/(s (T s+1))`` driven by the
    measured pulse, for a lag T."""

    def cost(T: float) -> float:
        m_T = ProcessModel("integrator_lag", {"K": K, "T": T, "delay": lag - T})
        return float(np.sum((r - simulate(m_T, t, u, u0, 0.0)) ** 2))

    return cost
