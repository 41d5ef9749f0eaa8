"""Inverse response: a zero in the right half plane over two lags, read off the undershoot
(after Balaguer, Alfaro & Arrieta, ISA Transactions 50(2), 2011).

``K (Tz s + 1) e^{-L s}/((T1 s + 1)(T2 s + 1))`` with ``Tz < 0``: after a step the output
first moves the wrong way (its initial slope is ``K Tz/(T1 T2)``), reaches a minimum,
crosses its initial level and settles at ``K du``. What is taken from Balaguer et al.:
the model structure and the idea of identifying it from the characteristic points of the
undershoot (its depth and time, and where the response crosses back through its initial
level). Their sequential formulas are not reproduced here: the readings below are
matched by the model's exact step response (:mod:`pipeline.models`) in the
least-squares sense, four parameters from seven readings.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from ..errors import NotApplicable
from ..events import EventData
from ..models import ProcessModel
from .base import fraction, refuse_moving_start, undershoot
from .registry import MethodResult, register

#: Rise levels read after the zero crossing (fractions of the change).
RISE_LEVELS = (0.5, 0.9)


def _unit(p: np.ndarray, tau: np.ndarray) -> np.ndarray:
    T1, T2, mTz, L = p
    m = ProcessModel("zero_two_lags", {"K": 1.0, "Tz": -mTz, "T1": T1, "T2": T2, "delay": L})
    return m.unit_step(tau)


@register(id="inverse_response", event="step", structures=("zero_two_lags",),
          references=("balaguer2011",),
          source="Balaguer, Alfaro & Arrieta 2011 (model and the undershoot's "
                 "characteristic points); readings matched by the exact step response",
          title="Inverse response, undershoot and zero crossing")
def inverse_response(ev: EventData) -> MethodResult:
    """``K (Tz s+1) e^{-L s}/((T1 s+1)(T2 s+1))``, ``Tz < 0``, from a step's undershoot.

    Readings on the fractional response ``h = (y - y0)/(y_ss - y0)`` (times since t0):

    * ``K = (y_ss - y0)/du``;
    * the band exit ``t_e``: ``h`` first below ``-max(1 %, 4 sigma)``;
    * the undershoot: its depth ``h_m < 0`` and time ``t_m`` (a local parabola's vertex,
      :func:`~pipeline.signal.extremum`), where ``h'(t_m) = 0``;
    * the zero crossing ``t_x``: ``h`` back through 0, and the rise times ``t50``,
      ``t90`` after it (:func:`~pipeline.signal.crossing_time`);
    * when the window has settled, the area above the response,
      ``integral (1 - h) dt = T1 + T2 - Tz + L`` (the mean residence time).

    ``(T1, T2, Tz, L)`` minimise the squared mismatch of the model's unit step response
    ``S`` at the readings: ``S(t_e) = -band``; the minimum of ``S`` is ``h_m``, at
    ``t_m`` (the time relative to ``t90``); ``S(t_x) = 0``, ``S(t50) = 0.5``,
    ``S(t90) = 0.9``; and the area (relative), from a few starting points; ``T1 >= T2``.

    Domain: a step whose response undershoots measurably
    (:func:`~pipeline.methods.base.undershoot`: deeper than 2 % of the change and the
    noise) and then rises through 90 % of its change; otherwise not applicable (a
    response without undershoot is a chain of lags; a ramp is an integrating process).
    """
    if ev.response == "ramp":
        raise NotApplicable("the output ramps without settling (an integrating process)")
    resp = fraction(ev)
    tau, h, sigma = resp
    refuse_moving_start(ev)
    u = undershoot(ev)
    if u is None:
        raise NotApplicable("no undershoot: the output does not first move the wrong way "
                            "(no right-half-plane zero to read)")
    K = ev.dy / ev.du
    hs = resp.hs
    i_m = int(np.searchsorted(tau, u["t"]))
    half = max(3, int(np.argmax(hs[i_m:] >= 0.0)))  # the dip spans [t0, t_x]
    lo, hi = max(0, i_m - half), min(tau.size, i_m + half)
    t_m, h_m, _ = resp.extremum(lo, hi, kind="min")
    t_x = resp.crossing(0.0, start=i_m, name="its initial level")
    i_x = int(np.searchsorted(tau, t_x))
    rise = [resp.crossing(lv, start=i_x) for lv in RISE_LEVELS]
    band = max(0.01, 4 * sigma)
    out = np.flatnonzero(hs[: i_m + 1] < -band)
    k = int(out[0]) if out.size else 0
    t_e = float(np.interp(-band, [hs[k], hs[k - 1]], [tau[k], tau[k - 1]])) if k else 0.0
    area = float(np.sum(((1 - h)[1:] + (1 - h)[:-1]) * np.diff(tau)) / 2) if ev.settled \
        else None
    t_ref = rise[-1]

    grid = np.linspace(0.0, 1.5 * t_x, 301)

    def residuals(p: np.ndarray) -> np.ndarray:
        s = _unit(p, np.array([t_e, t_x, *rise]))
        dip = _unit(p, grid)
        j = int(np.argmin(dip))
        res = [s[0] + band, dip[j] - h_m, (grid[j] - t_m) / t_ref, s[1],
               *(s[2:] - np.array(RISE_LEVELS))]
        if area is not None:
            res.append((p[0] + p[1] + p[2] + p[3]) / area - 1.0)
        return np.array(res)

    best = _solve(residuals, t_ref, t_e)
    T1, T2, mTz, L = best.x
    T1, T2 = max(T1, T2), min(T1, T2)
    diag = {"t0": ev.t0, "undershoot": -h_m, "t_undershoot": ev.t0 + t_m,
            "y_undershoot": ev.y0 + h_m * ev.dy, "t_zero": ev.t0 + t_x, "y_zero": ev.y0,
            "t_band_exit": ev.t0 + t_e, "band_fraction": band,
            **{f"t{round(lv * 100)}": ev.t0 + tr for lv, tr in zip(RISE_LEVELS, rise,
                                                                    strict=True)},
            **{f"y{round(lv * 100)}": ev.y0 + lv * ev.dy for lv in RISE_LEVELS},
            "area": area, "mismatch": float(np.sqrt(np.mean(best.fun ** 2)))}
    return MethodResult(ProcessModel("zero_two_lags", {"K": K, "Tz": -mTz, "T1": T1,
                                                       "T2": T2, "delay": L}), diag)


def _solve(residuals, t_ref: float, t_e: float):
    """Least squares from a few starting points (fractions of the 90 % time)."""
    lo = np.array([1e-6 * t_ref] * 3 + [0.0])
    hi = np.array([10 * t_ref] * 3 + [max(t_e, 1e-9 * t_ref)])
    best = None
    for f1, f2, fz in ((0.3, 0.05, 0.1), (0.25, 0.1, 0.2), (0.4, 0.02, 0.05), (0.15, 0.15, 0.3)):
        x0 = np.clip(np.array([f1, f2, fz, 0.5 * t_e / t_ref]) * t_ref, lo, hi)
        try:
            r = least_squares(residuals, x0, bounds=(lo, hi), x_scale=t_ref)
        except ValueError:
            continue
        if best is None or r.cost < best.cost:
            best = r
    if best is None or not math.isfinite(best.cost):
        raise NotApplicable("the readings admit no inverse-response model")
    return best
