"""Fit criteria: MSE (seed 001's J), ISE (seed 002 eq. 25) and MATLAB's NRMSE fit %."""

from __future__ import annotations

import numpy as np


def mse(y, y_hat) -> float:
    """Mean squared error J = 1/N sum (y_hat(k) - y(k))^2 (seed 001, thermal validation)."""
    e = np.asarray(y_hat, dtype=float) - np.asarray(y, dtype=float)
    return float(np.mean(e * e)) if e.size else float("nan")


def ise(t, y, y_hat) -> float:
    """Integral of the squared error over ``t`` (trapezoid rule), seed 002 eq. (25)."""
    e = np.asarray(y_hat, dtype=float) - np.asarray(y, dtype=float)
    return float(np.trapezoid(e * e, np.asarray(t, dtype=float))) if e.size > 1 else float("nan")


def fit_percent(y, y_hat) -> float:
    """NRMSE fit as MATLAB's ``compare``: 100 (1 - ||y - y_hat|| / ||y - mean(y)||)."""
    y = np.asarray(y, dtype=float)
    y_hat = np.asarray(y_hat, dtype=float)
    den = np.linalg.norm(y - y.mean())
    if y.size == 0 or den == 0:
        return float("nan")
    return float(100.0 * (1.0 - np.linalg.norm(y - y_hat) / den))


def fit_percent_of_errors(y: np.ndarray, e: np.ndarray) -> float:
    """``fit_percent(y, y - e)``, the same number, with two record-long copies fewer: the
    residual ``y - (y - e)`` as that computes it, then ``y`` (a fresh array the caller
    gives up) centred in place (each copy as long as a validation's held-out
    samples)."""
    if y.size == 0:
        return float("nan")
    r = np.subtract(y, e)
    np.subtract(y, r, out=r)
    num = np.sqrt(r.dot(r))
    del r
    y -= y.mean()
    den = np.sqrt(y.dot(y))
    if den == 0:
        return float("nan")
    return float(100.0 * (1.0 - num / den))
