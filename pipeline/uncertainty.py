"""Uncertainty of a least-squares fit under coloured noise: the effective sample size of the
residuals, the Jacobian covariance scaled by it, intervals, and a moving-block bootstrap.

The Gauss-Newton covariance of an output-error estimate, ``s^2 (J^T J)^-1`` (Ljung, System
Identification, 2nd ed., 1999, eq. 9.18 and sec. 9.3), assumes white residuals. With
coloured residuals (real plant noise, or what the model cannot explain) it is too small:
for regressors that vary slowly against the noise's correlation time
``J^T Sigma J ~ s^2 f J^T J`` with the long-run variance factor

    f = n / n_eff = 1 + 2 sum_{k>=1} rho_k

(for AR(1) noise ``(1 + phi) / (1 - phi)``, 9 at phi = 0.8: a standard error 3x too small).
:func:`variance_factor` estimates ``f`` from the residual autocorrelation with Geyer's
initial positive sequence (C. J. Geyer, "Practical Markov chain Monte Carlo", Statistical
Science 7(4):473-483, 1992: sums of adjacent lag pairs while they stay positive), which
needs no truncation lag; on a short window the residuals of a fitted model have lost some
of their slow content and the sum comes out low (5.5 instead of 9 on 200 samples of AR(1)
noise at 0.8), so the AR(1) factor of the lag-1 autocorrelation is a floor (exact for
AR(1) noise, about 1 for white noise), its estimate corrected for its small-sample bias
``-(1 + 4 rho_1) / n`` (F. H. C. Marriott, J. A. Pope, "Bias in the estimation of
autocorrelations", Biometrika 41:390-402, 1954). The intervals use Student's t with ``n_eff - p``
degrees of freedom (at least :data:`pipeline.refine.MIN_DOF`).

:func:`block_bootstrap_residuals` resamples residuals in moving blocks (H. R. Kuensch, "The
jackknife and the bootstrap for general stationary observations", Annals of Statistics
17(3):1217-1241, 1989), the block length four times the correlation length (at least
``n^(1/3)``), for percentile intervals from refits. It is an option, not the default: on
windows of a few hundred samples of AR(1) noise at 0.8 its intervals covered the truth in
about 80-87 % of 30 seeds (the Jacobian intervals above: 87-97 %), the known small-sample
shortfall of block resampling under strong correlation.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats


def autocorrelation(e: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation ``rho_0 .. rho_max_lag`` of ``e`` (mean removed, biased
    estimator, FFT)."""
    e = np.asarray(e, dtype=np.float64) - float(np.mean(e))
    n = e.size
    if n < 2 or not np.any(e):
        return np.r_[1.0, np.zeros(max(max_lag, 0))]
    m = 1 << int(math.ceil(math.log2(2 * n)))
    f = np.fft.rfft(e, m)
    acov = np.fft.irfft(f * np.conj(f), m)[: max_lag + 1]
    if not acov[0] > 1e-300:  # a constant series (to rounding): no correlation to read
        return np.r_[1.0, np.zeros(max(max_lag, 0))]
    return acov / acov[0]


#: From this many residuals on, :func:`variance_factor` takes only the leading
#: autocorrelations it needs: the initial positive sequence usually ends within a few
#: lags, and the FFT of all ``n // 3`` lags of a long residual takes time and several
#: record-long temporaries. First :data:`DIRECT_LAGS` direct products, then blockwise FFTs
#: for :data:`BLOCK_LAGS` lags in turn (:func:`_blockwise_acov`: memory of a few blocks);
#: only when the sequence has not ended by the last is the whole FFT taken (the same
#: numbers, to rounding).
DIRECT_FROM, DIRECT_LAGS = 4096, 32
BLOCK_LAGS = (1024, 16384)


def _pairs(rho: np.ndarray) -> np.ndarray:
    """Geyer's pair sums ``rho_2m + rho_2m+1`` of the autocorrelations ``rho``."""
    return rho[: rho.size // 2 * 2].reshape(-1, 2).sum(axis=1)


def _ended(rho: np.ndarray) -> bool:
    """Whether the initial positive sequence of ``rho`` ends within it."""
    return bool(np.any(_pairs(rho) <= 0))


def _blockwise_acov(x: np.ndarray, k: int) -> np.ndarray:
    """``sum_t x_t x_(t+j)`` for ``j = 0..k`` (``x`` centred) by FFTs of blocks of
    ``B >= k`` samples, each correlated with itself and the next block (an overlap-add
    correlation: exact, memory O(B), cost O(n log B)). A block is never longer than the
    series, and the FFT is as long as one block's lags need: before, a 20,000-sample
    residual took 262,144-point FFTs (issue 30 item 5; the same sums to rounding, 7-37x
    less time on 10-50 k samples: BENCHMARKS.md, "Residual spectra of the length they
    need")."""
    n = x.size
    b = min(max(4 * k, 1 << 16), max(n, 4 * k))
    m = 1 << int(math.ceil(math.log2(b + k + 1)))  # lags 0..k of a b-sample block with
    # the b + k samples from it: indices t + j < b + k, so no circular wrap
    acov = np.zeros(k + 1)
    for s in range(0, n, b):
        head = x[s: s + b]
        f = np.fft.rfft(head, m)
        g = np.fft.rfft(x[s: s + b + k], m)
        acov += np.fft.irfft(np.conj(f) * g, m)[: k + 1]
    return acov


def _leading(e: np.ndarray, lag: int) -> np.ndarray | None:
    """``rho_0 .. rho_k`` when the initial positive sequence of :func:`variance_factor`
    ends within them (a pair ``rho_2m + rho_2m+1 <= 0``): direct products, then blockwise
    FFTs (see :data:`DIRECT_FROM`); else None."""
    x = np.asarray(e, dtype=np.float64) - float(np.mean(e))
    n, k = x.size, min(DIRECT_LAGS - 1, lag)
    acov = np.array([float(x[: n - j] @ x[j:]) for j in range(k + 1)])
    if not acov[0] > 1e-300:
        return None  # a constant series: autocorrelation's own answer
    rho = acov / acov[0]
    if _ended(rho):
        return rho
    for want in BLOCK_LAGS:
        if want - 1 > lag and k == lag:
            return None  # all the lags asked for were taken and the sequence goes on
        k = min(want - 1, lag)
        if 8 * k > n:
            return None  # a short series: the whole FFT is as cheap
        acov = _blockwise_acov(x, k)
        rho = acov / acov[0]
        if _ended(rho):
            return rho
    return None


def variance_factor(e: np.ndarray, max_lag: int | None = None) -> float:
    """Long-run variance factor ``f = n / n_eff >= 1`` of the residuals ``e``: the larger
    of Geyer's initial positive sequence and the AR(1) factor ``(1 + rho_1)/(1 - rho_1)``
    (see the module docstring)."""
    n = int(np.asarray(e).size)
    if n < 8:
        return 1.0
    lag = min(n - 2, max_lag if max_lag is not None else max(16, n // 3))
    rho = _leading(e, lag) if n >= DIRECT_FROM else None
    if rho is None:
        rho = autocorrelation(e, lag)
    pairs = _pairs(rho)
    stop = np.flatnonzero(pairs <= 0)
    keep = pairs[: stop[0]] if stop.size else pairs
    if keep.size > 1:  # initial monotone sequence: each pair no larger than the one before
        keep = np.minimum.accumulate(keep)
    f = -1.0 + 2.0 * float(np.sum(keep))
    r1 = float(rho[1])
    r1 = min(max(r1 + (1 + 4 * r1) / n, 0.0), 0.99)  # small-sample bias of rho_1
    return max(f, (1 + r1) / (1 - r1), 1.0)


def t_quantile(dof: float, level: float = 0.95) -> float:
    """Two-sided Student-t quantile (normal for many degrees of freedom)."""
    return float(stats.t.ppf(0.5 + level / 2, max(dof, 1.0)))


def chi2_upper(dof: float, alpha: float) -> float:
    """The chi-square quantile with ``dof`` degrees of freedom that chance exceeds with
    probability ``alpha``."""
    return float(stats.chi2.isf(alpha, max(dof, 1.0)))


def residual_variance(resid: np.ndarray, n_params: int, factor: float) -> float:
    """``s^2 = |e|^2 / (n - f n_params)``, at least ``n / 2`` in the divisor (see
    :func:`covariance`)."""
    n = resid.size
    return float(resid @ resid) / max(n - factor * n_params, n / 2, 1)


def covariance(jac: np.ndarray, resid: np.ndarray, n_params: int, factor: float
               ) -> np.ndarray:
    """``s^2 f (J^T J)^+`` with ``s^2 = |e|^2 / (n - f n_params)`` (pseudo-inverse: a
    parameter the data do not determine gets a huge variance, not an exception).

    The fit absorbs part of coloured noise: ``E|e|^2 = sigma^2 (n - tr(P R))`` with ``P``
    the projection on the Jacobian's columns and ``R`` the noise correlation, about
    ``n - f n_params`` for regressors slower than the noise (``n - n_params`` when white),
    so the residual variance is corrected by those degrees of freedom (at least n / 2:
    beyond that the residuals are a misfit, not noise)."""
    return residual_variance(resid, n_params, factor) * factor * gram_pinv(jac)


def gram_pinv(jac: np.ndarray) -> np.ndarray:
    """``(J^T J)^+``, the Gram matrix scaled to a unit diagonal first (so columns of very
    different sizes do not fall below the pseudo-inverse's relative cut-off)."""
    jtj = jac.T @ jac
    scale = np.sqrt(np.maximum(np.diag(jtj), 1e-300))
    return np.linalg.pinv(jtj / np.outer(scale, scale), rcond=1e-12) / np.outer(scale, scale)


def correlation_length(e: np.ndarray) -> int:
    """Samples until the residual autocorrelation first drops below 1/e (at least 1)."""
    n = int(np.asarray(e).size)
    rho = autocorrelation(e, max(1, min(n - 1, n // 4)))
    below = np.flatnonzero(rho < math.exp(-1.0))
    return int(below[0]) if below.size else max(1, n // 4)


def block_bootstrap_residuals(e: np.ndarray, n_boot: int, seed: int = 0) -> np.ndarray:
    """``n_boot`` moving-block resamples of ``e`` (rows), each as long as ``e``."""
    e = np.asarray(e, dtype=np.float64)
    n = e.size
    block = int(min(n, max(4 * correlation_length(e), round(n ** (1 / 3)))))
    n_blocks = int(math.ceil(n / block))
    rng = np.random.default_rng(seed)
    starts = rng.integers(0, n - block + 1, size=(n_boot, n_blocks))
    idx = (starts[:, :, None] + np.arange(block)[None, None, :]).reshape(n_boot, -1)[:, :n]
    return e[idx]
