"""Impulse-response methods, first and second order (seed 001 sections 4-5, seed 000).

An impulse event (``pipeline.segment``) is a short pulse of the input off its baseline
``u0 = u_ss``; its strength is the measured ``area = integral (u - u0) dt``. The seeds'
formulas assume a unit-area ideal impulse at ``t = 0`` from zero initial conditions; here
times count from the pulse start ``t0``, the output is taken relative to its baseline and
every gain formula is divided by the measured area (ERRATA [S1] 5, [S0] 6).

Baseline. The output baseline is the settled level before the pulse (``ev.y0``), pooled
with the last tenth of the window when the model identified from ``ev.y0`` says the
response has died out there (below 1 % of the peak; its small residual is subtracted).
Seed 001 reads ``y_ss = y0`` from the last 11 samples (ERRATA [S1] 2). The output areas
are sensitive to the baseline (an offset ``d`` adds ``d x integration length``), so the
readings are then repeated from the pooled baseline, reported as ``baseline``.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import NotApplicable
from ..events import EventData
from ..models import ProcessModel
from ..signal import crossing_time, smooth
from ..simulation import simulate
from .base import clip_delay
from .prepared import Response, per_event
from .registry import MethodResult, register
from .second_order import check_oscillation, oscillation, zeta_from_overshoot

#: Seed 001 writes 0.368 (ERRATA [S1] 13: e^-1 = 0.36788, T biased by -0.03 %).
LEVEL_DECAY = 0.368
#: First order: integrate the output over this many time constants after the peak; the
#: exponential tail beyond is added in closed form (e^-5: 0.7 % of the area, from the model).
#: Shorter spans average less noise, longer ones multiply a baseline error (error x span).
AREA_SPAN_FO = 5.0
#: Second order: integrate over at most this many envelope time constants 1/(zeta wn).
AREA_SPAN_SO = 8.0
#: Pool the window's tail into the baseline when the model's response there is below this
#: fraction of the peak (the model's residual is subtracted from the tail first).
TAIL_RESIDUAL = 0.01


# -- shared readings ------------------------------------------------------------------------
@per_event
def _deviation(ev: EventData, base: float) -> tuple[Response, float]:
    """``(response, a)``: time since the pulse start and the output deviation from
    ``base`` scaled by its dominant excursion ``a`` (signed), so that ``h`` peaks near +1,
    with the noise in units of ``h`` (read once per event and baseline: both impulse
    methods start from the pre-pulse baseline)."""
    if ev.area == 0 or not np.isfinite(ev.area):
        raise NotApplicable("the impulse has no area (the input did not leave its baseline)")
    i = ev.i0
    tau, d = ev.t[i:] - ev.t0, ev.y[i:] - base
    if tau.size < 10:
        raise NotApplicable("fewer than 10 samples after the impulse")
    ds = smooth(d, ev.noise / max(float(np.max(np.abs(d))), 1e-300))
    j = int(np.argmax(np.abs(ds)))
    a = float(ds[j])
    if a == 0 or abs(a) <= 3 * ev.noise:
        raise NotApplicable("no measurable response to the impulse (peak <= 3 sigma)")
    return Response(tau, d / a, ev.noise / abs(a)), a


def _model_response(ev: EventData, model: ProcessModel) -> np.ndarray:
    """Deviation output of ``model`` driven by the measured pulse, from the pulse start."""
    i = ev.i0
    return simulate(model, ev.t[i:], ev.u[i:], ev.u0, 0.0)


def _pooled_baseline(ev: EventData, y_model: np.ndarray, a: float) -> tuple[float, str, int]:
    """``(baseline, source, n_samples)``: the pre-pulse baseline ``ev.y0``, pooled with the
    last tenth of the window (at least 11 samples, as seed 001) when the identified model's
    response there is below ``TAIL_RESIDUAL`` of the peak; that residual is subtracted."""
    n_pre = ev.i0
    n_after = ev.t.size - n_pre
    n_tail = max(11, n_after // 10)
    if n_tail >= n_after // 2:
        return ev.y0, "pre-pulse", n_pre
    resid = y_model[-n_tail:]
    if not np.max(np.abs(resid)) <= TAIL_RESIDUAL * abs(a):
        return ev.y0, "pre-pulse", n_pre
    tail = float(np.mean(ev.y[-n_tail:] - resid))
    return (n_pre * ev.y0 + n_tail * tail) / (n_pre + n_tail), "pre-pulse + tail", n_pre + n_tail


def _integral(t: np.ndarray, y: np.ndarray, lo: float, hi: float) -> float:
    """Integral over ``[lo, hi]`` of the linear interpolant of the samples (trapezoid)."""
    lo, hi = max(lo, float(t[0])), min(hi, float(t[-1]))
    if hi <= lo:
        return 0.0
    inside = (t > lo) & (t < hi)
    tt = np.concatenate([[lo], t[inside], [hi]])
    yy = np.concatenate([np.interp([lo], t, y), y[inside], np.interp([hi], t, y)])
    return float(np.sum((yy[1:] + yy[:-1]) * np.diff(tt)) / 2)


def _impulse_delay(ev: EventData, tau: np.ndarray, h: np.ndarray, y_model: np.ndarray,
                   a: float, sig: float) -> tuple[float, dict]:
    """Dead time (seed 001 "Time delay", ERRATA [S1] 14): when the output leaves the band
    ``max(1 %, 4 sigma)`` of its peak, minus the time the undelayed model driven by the
    measured pulse (``y_model``) needs to leave it. Never negative."""
    frac = max(0.01, 4 * sig)
    t_e, t_b = _band_exit(tau, h, frac, sig), _band_exit(tau, y_model / a, frac, 0.0)
    if t_e is None or t_b is None:
        return 0.0, {"band_fraction": frac}
    delay, ddiag = clip_delay(t_e - t_b)
    return delay, {"t_band_exit": ev.t0 + t_e, "band_fraction": frac, **ddiag}


def _band_exit(tau: np.ndarray, h: np.ndarray, frac: float, sig: float) -> float | None:
    hs = smooth(h, sig) if 4 * sig > 0.1 * frac else h  # smooth only when noise matters
    out = np.flatnonzero(np.abs(hs) > frac)
    if out.size == 0:
        return None
    i = int(out[0])
    if i == 0:
        return float(tau[0])
    h0, h1 = abs(hs[i - 1]), abs(hs[i])
    return float(tau[i - 1] + (frac - h0) * (tau[i] - tau[i - 1]) / (h1 - h0))


# -- first order ----------------------------------------------------------------------------
@register(id="first_order_impulse", event="impulse", structures=("first_order",),
          references=("busoniu", "rake1980"),
          source="seed 001 'Impulse response models of first-order systems' (36.8 % decay, "
                 "K = y_ss/u_ss or K = y_max T); seed 000 section I impulse response; "
                 "ERRATA [S1] 3-6, 13",
          title="First order, impulse decay")
def first_order_impulse(ev: EventData, level: float = LEVEL_DECAY) -> MethodResult:
    """K e^{-delay s}/(Ts+1) from an impulse response (seed 001; seed 000 section I).

    1. Peak ``y_max`` at ``t_peak``; ``T = t(decay to y0 + 0.368 (y_max - y0)) - t_peak``
       (seed 001 step 2, ERRATA [S1] 4: the decay is read from the peak, not from t0).
       After a rectangular pulse of width ``w`` a lag decays as a pure exponential, so
       ``T`` is exact for any width. Noisy data: the decay is read from the smoothed
       maximum (not before the pulse end), its value taken on the decay curve (a one-sided
       quadratic fit of the raw samples over the top 20 % of the decay): any start point on
       the exponential gives the same ``T``, so a cusp blurred by smoothing does not bias
       it. The 36.8 % time is read with :func:`~pipeline.signal.crossing_time`.
       ``y_max`` (for ``K_peak``) is that decay traced back, ``e^{+dt/T}``, to the cusp:
       the pulse end plus the dead time.
    2. Gains, all divided by the measured pulse area ``A`` (ERRATA [S1] 5), all reported:

       * ``K_steady_state = y_ss/u_ss`` (seed 001, nonzero initial conditions), as
         written, ``y_ss = y0`` being the baseline. It assumes the operating point lies
         on a static line through the origin, ``y0 = K u0`` (ERRATA [S1] 6); real data
         have offsets. None when ``u_ss = 0``.
       * ``K_peak = y_max T / A`` (seed 001, zero initial conditions: ``y_max = K/T``). A
         pulse of width ``w`` reaches only ``K (A/w)(1 - e^{-w/T})``, so ``K_peak`` is
         biased by about ``-w/(2T)`` (-2.5 % for a 0.2 s pulse on T = 4 s): the peak method
         needs a pulse short relative to T. ``K_peak_rect`` corrects it exactly for a
         rectangular pulse.
       * ``K_area = integral (y - y0) dt / A``: the DC gain is the ratio of the output's
         area to the input's (final value theorem), exact for any pulse shape and width.
         Integrated over ``5 T`` after the peak plus the exponential tail beyond it.

       The model uses ``K_area`` (offset-free, width-free, averages the noise).
    3. Dead time: the band exit of the output minus that of the undelayed model driven by
       the measured pulse (seed 001 "Time delay", ERRATA [S1] 14).

    Domain: an impulse event whose response rises measurably above the noise, peaks inside
    the window and decays to 36.8 % of its peak; otherwise ``not_applicable``.
    """
    r = _fo_fit(ev, ev.y0, level)
    base, source, _ = _pooled_baseline(ev, r["y_model"], r["a"])
    if source != "pre-pulse":
        r = _fo_fit(ev, base, level)
    tau, h, a, sig = r["tau"], r["h"], r["a"], r["sig"]
    T, t_pk, y_pk, A, w = r["T"], r["t_peak"], r["y_peak"], ev.area, ev.duration
    K_area = r["K_area"]
    K_peak = a * y_pk * T / A
    K_rect = a * y_pk * w / (A * -math.expm1(-w / T)) if w > 0 else K_peak
    K_ss = base / ev.u_ss if ev.u_ss != 0 else None
    delay, ddiag = _impulse_delay(ev, tau, h, r["y_model"], a, sig)
    diag = {"t0": ev.t0, "baseline": base, "baseline_source": source,
            "t_peak": ev.t0 + t_pk, "y_peak": base + a * y_pk,
            "t_decay_start": ev.t0 + r["t_read"], "y_decay_start": base + a * r["y_read"],
            "t_decay": ev.t0 + r["t_read"] + T, "y_decay": base + a * level * r["y_read"],
            "level": level,
            "area": A, "pulse_width": w, "output_area": K_area * A,
            "K_steady_state": K_ss, "K_peak": K_peak, "K_peak_rect": K_rect,
            "K_area": K_area, "K_choice": "K_area", **ddiag}
    return MethodResult(ProcessModel("first_order", {"K": K_area, "T": T, "delay": delay}),
                        diag)


def _fo_fit(ev: EventData, base: float, level: float) -> dict:
    resp, a = _deviation(ev, base)
    (tau, h, sig), hs = resp, resp.hs
    # a lag keeps rising while the pulse is on: the peak is not before the pulse end
    i_end = min(int(np.searchsorted(tau, ev.duration)), tau.size - 1)
    j = max(int(np.argmax(hs)), i_end)
    if j >= tau.size - 5:
        raise NotApplicable("the response peaks at the end of the window")
    t_j, y_j = float(tau[j]), float(h[j])
    if hs is not h:  # noisy: read the value on the decay curve (quadratic over its top 20 %)
        k = max(j + int(np.argmax(hs[j:] < 0.8 * hs[j])), j + 5)
        y_j = float(np.polyfit(tau[j:k] - t_j, h[j:k], 2)[-1])
    if not y_j > 0:
        raise NotApplicable("no measurable peak")
    t_c = crossing_time(tau, h / y_j, level, sig / y_j, start=j, falling=True,
                        name=f"{level:.1%} of the peak")
    T = t_c - t_j
    if not T > 0:
        raise NotApplicable("the response does not decay after its peak")
    t_pk, y_pk = t_j, y_j
    if hs is not h:
        # Smoothing blurs the cusp and moves its maximum late. The peak of a lag driven by
        # a pulse is at the pulse end plus the dead time (the band exit less the time the
        # pulse needs to get there); its value is the decay e^{-t/T} traced back to it.
        frac = max(0.01, 4 * sig)
        t_e = _band_exit(tau, h, frac, sig) or 0.0
        t_end = float(tau[i_end])
        t_pk = min(t_end + max(0.0, t_e - frac * t_end), t_j)
        y_pk = y_j * math.exp((t_j - t_pk) / T)
    t_cut = min(t_j + AREA_SPAN_FO * T, float(tau[-1]))
    tail = y_j * T * math.exp(-(t_cut - t_j) / T)
    K_area = a * (_integral(tau, h, 0.0, t_cut) + tail) / ev.area
    y_model = _model_response(ev, ProcessModel("first_order", {"K": K_area, "T": T}))
    return {"tau": tau, "h": h, "a": a, "sig": sig, "T": T, "t_peak": t_pk, "y_peak": y_pk,
            "t_read": t_j, "y_read": y_j, "K_area": K_area, "y_model": y_model}


# -- second order ---------------------------------------------------------------------------
@register(id="second_order_impulse", event="impulse",
          structures=("second_order",),
          references=("busoniu",),
          source="seed 001 'Impulse response models of second-order systems' (areas A+/A-, "
                 "period, K from steady state or first peak); ERRATA [S1] 1, 2, 5, 6, 8",
          title="Second order, impulse areas and period")
def second_order_impulse(ev: EventData, period: str = "crossings") -> MethodResult:
    """Underdamped second order from an impulse response (seed 001).

    1. Baseline crossings ``t00`` (the pulse start), ``t01``, ``t02``; areas
       ``A+ = int_{t00}^{t01} (y - y0)``, ``A- = int_{t01}^{t02} (y0 - y)`` (ERRATA [S1] 1,
       2); ``M = A-/A+``, ``zeta = ln(1/M)/sqrt(pi^2 + ln^2 M)``.
    2. Period ``T0``; ``wn = 2 pi/(T0 sqrt(1 - zeta^2))``. Seed 001 reads ``T0 = t3 - t1``
       (two peaks) or ``2 (t2 - t1)`` (peak, valley): ``period="peaks"``. The default
       ``period="crossings"`` uses ``T0 = 2 (t02 - t01)``: after the pulse the response is
       one damped sinusoid, whose zeros are spaced by the same half period as its extrema,
       and a zero crossing (steepest slope) is read several times more precisely than a
       flat peak under noise. Both are reported (``period_crossings``, ``period_peaks``).
    3. Gains, divided by the measured pulse area ``A`` (ERRATA [S1] 5), all reported:

       * ``K_steady_state = y_ss/u_ss`` as written (nonzero initial conditions, ``y_ss``
         the baseline; assumes ``y0 = K u0``, ERRATA [S1] 6); None when ``u_ss = 0``.
       * ``K_peak`` from ``y(t1) = K wn e^{-zeta arccos(zeta)/sqrt(1 - zeta^2)}`` (seed 001,
         zero initial conditions; a pulse of finite width lowers the peak slightly).
       * ``K_lobes = A+/((1 + M) A) = A+^2/((A+ + A-) A)`` from ``A+ = K + K M`` (seed 001).
       * ``K_area = integral (y - y0) dt / A`` over the whole response (final value
         theorem: exact for any pulse shape, independent of ``M``), up to ``8/(zeta wn)``.

       The model takes the better conditioned of the two offset-free area estimates
       (``K_choice``): the one with the smaller standard error from white noise and the
       baseline's uncertainty (``K_area_se``, ``K_lobes_se``; an offset ``d`` in the baseline adds
       ``d x length`` to an area, so the long ``K_area`` integral loses on short or noisy
       records). ``K_area`` needs the decay inside the window (envelope below 1 %).
    4. Dead time as in :func:`first_order_impulse`.

    Domain: an impulse event with an oscillating response: a first lobe above the noise and
    at least two baseline crossings after it (else ``not_applicable``: overdamped or
    first-order responses never cross back), with ``0 < M < 1``, a valley significant
    against the coloured-noise sigma and a first lobe as long as the half period
    (:func:`~pipeline.methods.second_order.check_oscillation`).
    """
    if period not in ("crossings", "peaks"):
        raise NotApplicable(f"unknown period reading {period!r}")
    r = _so_fit(ev, ev.y0, period)
    base, source, n_base = _pooled_baseline(ev, r["y_model"], r["a"])
    if source != "pre-pulse":
        r = _so_fit(ev, base, period)
    tau, h, a, sig, osc = r["tau"], r["h"], r["a"], r["sig"], r["osc"]
    zeta, wn, M, A = r["zeta"], r["wn"], r["M"], ev.area
    s = math.sqrt(1.0 - zeta**2)
    K_peak = a * osc["h1"] / (wn * math.exp(-zeta * math.acos(zeta) / s)) / A
    K_ss = base / ev.u_ss if ev.u_ss != 0 else None
    # standard errors (units of h) of the two area estimates: white noise + baseline
    dt = float(np.median(np.diff(tau)))
    s2, sb2 = sig * sig, sig * sig / max(n_base, 1)
    Ap, Am, t01, t02 = r["A_plus"], r["A_minus"], r["t01"], r["t02"]
    gp, gm = Ap * (Ap + 2 * Am) / (Ap + Am) ** 2, -(Ap**2) / (Ap + Am) ** 2
    var_lobes = (s2 * dt * (gp * gp * t01 + gm * gm * (t02 - t01))
                 + sb2 * (gp * t01 - gm * (t02 - t01)) ** 2)
    L = r["t_cut"]
    var_area = s2 * dt * L + sb2 * L * L
    se = {"K_area_se": abs(a / A) * math.sqrt(var_area),
          "K_lobes_se": abs(a / A) * math.sqrt(var_lobes)}
    use_area = r["complete"] and var_area <= var_lobes
    K = r["K_area"] if use_area else r["K_lobes"]
    undelayed = ProcessModel("second_order", {"K": K, "zeta": zeta, "wn": wn})
    delay, ddiag = _impulse_delay(ev, tau, h, _model_response(ev, undelayed), a, sig)
    # after the pulse (width w, centred at w/2) the response crosses its baseline one half
    # period after it starts: the rise must agree with the period (check_oscillation)
    check_oscillation(osc, sig, t02 - t01, t01 - delay, t02 - t01 + ev.duration / 2,
                      level=0.0)
    diag = {"t0": ev.t0, "baseline": base, "baseline_source": source,
            "t00": ev.t0, "t01": ev.t0 + t01, "t02": ev.t0 + t02,
            "A_plus": a * Ap, "A_minus": a * Am, "overshoot": M,
            "t_peak1": ev.t0 + osc["t1"], "y_peak1": base + a * osc["h1"],
            "t_valley1": ev.t0 + osc["t2"], "y_valley1": base + a * osc["h2"],
            "t_peak2": ev.t0 + osc["t3"] if osc["t3"] is not None else None,
            "period": r["T0"], "period_crossings": r["T0_crossings"],
            "period_peaks": r["T0_peaks"], "period_reading": period,
            "area": A, "pulse_width": ev.duration,
            "K_steady_state": K_ss, "K_peak": K_peak, "K_lobes": r["K_lobes"],
            "K_area": r["K_area"], **se, "K_choice": "K_area" if use_area else "K_lobes",
            **ddiag}
    return MethodResult(
        ProcessModel("second_order", {"K": K, "zeta": zeta, "wn": wn, "delay": delay}), diag)


def _so_fit(ev: EventData, base: float, period: str) -> dict:
    resp, a = _deviation(ev, base)
    (tau, h, sig), hs = resp, resp.hs
    thr = max(3 * sig, 1e-9)
    first = np.flatnonzero(hs > thr)
    if first.size == 0 or not (hs[first[0]:] < -thr).any():
        raise NotApplicable("fewer than two baseline crossings: the response does not "
                            "oscillate (overdamped or first order)")
    try:
        osc = oscillation(resp, level=0.0)
    except NotApplicable as exc:
        raise NotApplicable(f"no oscillation about the baseline ({exc.reason})") from exc
    i1 = int(np.searchsorted(tau, osc["t1"]))
    i2 = int(np.searchsorted(tau, osc["t2"]))
    t01 = resp.crossing(0.0, start=i1, falling=True, name="the baseline")
    try:
        t02 = resp.crossing(0.0, start=max(i2, i1 + 1), name="the baseline")
    except NotApplicable as exc:
        raise NotApplicable("fewer than two baseline crossings: the response does not "
                            "come back across its baseline within the window") from exc
    if not 0.0 < t01 < osc["t2"] < t02:
        raise NotApplicable("baseline crossings and extrema out of order")
    A_plus = _integral(tau, h, 0.0, t01)
    A_minus = -_integral(tau, h, t01, t02)
    if not A_plus > 0:
        raise NotApplicable("the first lobe has no area")
    M = A_minus / A_plus
    if not 0.0 < M < 1.0:
        raise NotApplicable(f"area ratio M = A-/A+ = {M:.3g} outside (0, 1)")
    zeta = zeta_from_overshoot(M)
    T0_cross = 2.0 * (t02 - t01)
    T0_peaks = (osc["t3"] - osc["t1"] if osc["t3"] is not None
                else 2.0 * (osc["t2"] - osc["t1"]))
    T0 = T0_cross if period == "crossings" else T0_peaks
    wn = 2.0 * math.pi / (T0 * math.sqrt(1.0 - zeta**2))
    t_cut = min(float(tau[-1]), AREA_SPAN_SO / (zeta * wn))
    K_area = a * _integral(tau, h, 0.0, t_cut) / ev.area
    K_lobes = a * A_plus / ((1.0 + M) * ev.area)
    complete = math.exp(-zeta * wn * (t_cut - osc["t1"])) <= 0.01
    K = K_area if complete else K_lobes
    y_model = _model_response(ev, ProcessModel("second_order", {"K": K, "zeta": zeta,
                                                                "wn": wn}))
    return {"tau": tau, "h": h, "a": a, "sig": sig, "osc": osc, "t01": t01, "t02": t02,
            "A_plus": A_plus, "A_minus": A_minus, "M": M, "zeta": zeta, "wn": wn,
            "T0": T0, "T0_crossings": T0_cross, "T0_peaks": T0_peaks, "t_cut": t_cut,
            "K_area": K_area, "K_lobes": K_lobes, "complete": complete, "y_model": y_model}
