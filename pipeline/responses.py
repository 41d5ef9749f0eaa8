"""Closed-form unit step responses of the rational parts of the model structures (the
structure table in :mod:`pipeline.models` points at them; seed 000 section I, seed 001
"Underdamped 2nd order step response")."""

from __future__ import annotations

import math

import numpy as np
from scipy.special import gammainc

#: Two lags within this share of each other are taken by the form without cancellation
#: (:func:`two_lag_step`); farther apart the textbook form loses at most 1e-12, and it
#: is kept there so that well-separated lags give the numbers they always gave.
NEAR_EQUAL = 1e-4


def two_lag_step(t: np.ndarray, T1: float, T2: float) -> np.ndarray:
    """Unit step response of 1/((T1 s+1)(T2 s+1)), ``T1 >= T2`` (swapped if not), written
    without the cancellation of the textbook form ``1 - (T1 e^{-t/T1} - T2 e^{-t/T2})/(T1 -
    T2)`` near equal lags (it loses about ``1e-16 T1/(T1 - T2)``): ``1 - e^{-a t} (1 + a t
    phi((b - a) t))`` with ``a = 1/T1 <= b = 1/T2`` and ``phi(x) = (1 - e^{-x})/x``
    (``phi(0) = 1``: equal lags, ``gammainc(2, t/T)``) where the lags are within
    :data:`NEAR_EQUAL` of each other; ``T2 = 0`` is one lag."""
    T1, T2 = max(T1, T2), min(T1, T2)
    if T2 <= 0:
        return -np.expm1(-t / T1) if T1 > 0 else np.ones_like(t)
    if T1 - T2 > NEAR_EQUAL * T1:  # the textbook form, within 1e-12 there
        return 1.0 - (T1 * np.exp(-t / T1) - T2 * np.exp(-t / T2)) / (T1 - T2)
    if T1 == T2:
        return gammainc(2.0, t / T1)
    a = 1.0 / T1
    t = np.asarray(t, dtype=np.float64)
    return 1.0 - np.exp(-a * t) * (1.0 + a * t * _phi((1.0 / T2 - a) * t))


def _phi(x: np.ndarray) -> np.ndarray:
    """``(1 - e^{-x})/x``, 1 at ``x = 0`` (no cancellation: ``expm1``)."""
    x = np.asarray(x, dtype=np.float64)
    out = np.ones_like(x)
    nz = x != 0
    out[nz] = -np.expm1(-x[nz]) / x[nz]
    return out


def second_order_step(t: np.ndarray, zeta: float, wn: float) -> np.ndarray:
    """Unit step response of wn^2/(s^2+2 zeta wn s+wn^2) (seed 001, underdamped formula)."""
    if zeta < 1:
        wd = wn * math.sqrt(1 - zeta**2)
        return 1.0 - np.exp(-zeta * wn * t) * (
            np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t)
        )
    if zeta == 1:
        return gammainc(2.0, wn * t)
    r = math.sqrt(zeta**2 - 1)
    return two_lag_step(t, 1 / (wn * (zeta - r)), 1 / (wn * (zeta + r)))


#: A damping ratio this close to 1 is taken as this far below it in
#: :func:`lag_pair_step` (the closed form divides by the damped frequency; the step
#: response moves by about this much).
PAIR_ZETA_GAP = 1e-7


def lag_pair_step(t: np.ndarray, T: float, zeta: float, wn: float) -> np.ndarray:
    """Unit step response of ``wn^2/((T s+1)(s^2+2 zeta wn s+wn^2))`` with ``zeta < 1``: a
    lag behind a lightly damped pair. Partial fractions: ``1 + A e^(-t/T) + e^(-zeta wn
    t) (B cos(wd t) + C sin(wd t))`` with ``A = -(wn T)^2/(1 - 2 zeta wn T + (wn T)^2)``
    (the residue at ``s = -1/T``; the denominator is ``(wn T - zeta)^2 + 1 - zeta^2 >
    0``), ``B = -1 - A`` (``y(0) = 0``) and ``C = (A/T + zeta wn B)/wd`` (``y'(0) = 0``;
    ``y''(0) = 0`` follows, the relative degree being 3), ``wd = wn sqrt(1 - zeta^2)``.
    ``T = 0`` is the pair alone (:func:`second_order_step`)."""
    t = np.asarray(t, dtype=np.float64)
    if T <= 0:
        return second_order_step(t, zeta, wn)
    zeta = min(float(zeta), 1.0 - PAIR_ZETA_GAP)
    wT = wn * T
    A = -wT * wT / ((wT - zeta) ** 2 + 1.0 - zeta * zeta)
    B = -1.0 - A
    sigma = zeta * wn
    wd = wn * math.sqrt(1.0 - zeta * zeta)
    C = (A / T + sigma * B) / wd
    decay = np.exp(-sigma * t)
    return 1.0 + A * np.exp(-t / T) + decay * (B * np.cos(wd * t) + C * np.sin(wd * t))


def two_lag_impulse(t: np.ndarray, T1: float, T2: float) -> np.ndarray:
    """Impulse response of 1/((T1 s+1)(T2 s+1)) (the derivative of :func:`two_lag_step`):
    ``(e^{-t/T1} - e^{-t/T2})/(T1 - T2) = t e^{-t/T1} phi((1/T2 - 1/T1) t)/(T1 T2)``, the
    second form without the first's cancellation near equal lags."""
    T1, T2 = max(T1, T2), min(T1, T2)
    if T2 <= 0:
        return np.exp(-t / T1) / T1 if T1 > 0 else np.zeros_like(t)
    if T1 - T2 > NEAR_EQUAL * T1:
        return (np.exp(-t / T1) - np.exp(-t / T2)) / (T1 - T2)
    t = np.asarray(t, dtype=np.float64)
    return t * np.exp(-t / T1) * _phi((1.0 / T2 - 1.0 / T1) * t) / (T1 * T2)


def integrator_lag_step(t: np.ndarray, T: float) -> np.ndarray:
    """Unit step response of 1/(s (T s+1)): ``t - T (1 - e^{-t/T})``, a ramp lagging by T."""
    return t + T * np.expm1(-t / T) if T > 0 else np.asarray(t, dtype=np.float64)


def lead_lag_step(t: np.ndarray, Tz: float, T: float) -> np.ndarray:
    """Unit step response of (Tz s+1)/(T s+1): ``1 - (1 - Tz/T) e^{-t/T}`` (``Tz/T`` at 0+)."""
    if T <= 0:
        return np.ones_like(t)
    return 1.0 - (1.0 - Tz / T) * np.exp(-t / T)


def zero_lags_time_scale(lags: float, Tz: float) -> float:
    # the mean residence time sum(T) - Tz, but a lead never shortens it below the lags'
    return lags + max(0.0, -Tz)
