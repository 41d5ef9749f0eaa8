"""Closed-form unit step responses of the rational parts of the model structures (the
structure table in :mod:`pipeline.models` points at them; seed 000 section I, seed 001
"Underdamped 2nd order step response")."""

from __future__ import annotations

import math

import numpy as np
from scipy.special import gammainc


def two_lag_step(t: np.ndarray, T1: float, T2: float) -> np.ndarray:
    """Unit step response of 1/((T1 s+1)(T2 s+1)); equal lags and T2 = 0 handled exactly."""
    T1, T2 = max(T1, T2), min(T1, T2)
    if T2 <= 0:
        return -np.expm1(-t / T1) if T1 > 0 else np.ones_like(t)
    if abs(T1 - T2) <= 1e-9 * T1:
        return gammainc(2.0, t / T1)
    return 1.0 - (T1 * np.exp(-t / T1) - T2 * np.exp(-t / T2)) / (T1 - T2)


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


def two_lag_impulse(t: np.ndarray, T1: float, T2: float) -> np.ndarray:
    """Impulse response of 1/((T1 s+1)(T2 s+1)) (the derivative of :func:`two_lag_step`)."""
    T1, T2 = max(T1, T2), min(T1, T2)
    if T2 <= 0:
        return np.exp(-t / T1) / T1 if T1 > 0 else np.zeros_like(t)
    if abs(T1 - T2) <= 1e-9 * T1:
        return t * np.exp(-t / T1) / T1**2
    return (np.exp(-t / T1) - np.exp(-t / T2)) / (T1 - T2)


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
