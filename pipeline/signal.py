"""The signal toolbox: reading a sampled, noisy response robustly (DESIGN.md "signal.py").

Used by segmentation and by every method alike; pure functions on numpy arrays.

The sources read values "off the graph" (seed 001: "identifying this point on the graph";
seed 002: t33, t70, ...). On a sampled, noisy record that reading is done here:

* :func:`noise_estimate` / :func:`noise_sigma` - the output noise: its marginal standard
  deviation (right for coloured noise), lag-1 autocorrelation and correlation time, from a
  robust variogram of high-order differences (robust to steps, spikes, the smooth response
  and sensor quantisation).
* :func:`smooth` - Savitzky-Golay smoothing, only where there is noise; :func:`savgol`, the
  filter in ``O(N log w)`` for long windows (a direct convolution, ``N w``, made the
  smoothing over 2 % of a long event quadratic in its length).
* :func:`crossing_time` - the time a response first reaches a fraction of its change.
  Noise-free: linear interpolation between the two samples around the crossing.
  Noisy: a preliminary crossing on a smoothed copy, refined by a local quadratic
  least-squares fit of the raw samples around it (many samples average the noise; the
  quadratic removes the curvature bias of a straight line). A first noisy sample across
  the level does not decide the reading.
* :func:`value_at` - the response at a given time (a symmetric local parabola).
* :func:`extremum` - a peak or valley, refined the same way (vertex of a local parabola).
* :func:`interp_cross` - the linear-interpolation crossing between two samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import oaconvolve, savgol_coeffs, savgol_filter
from scipy.special import comb
from scipy.stats import norm

from .errors import NotApplicable

#: Relative noise below which a response is treated as noise-free (pure interpolation).
NOISE_FREE = 1e-7


#: Order of the differences the noise is read from: a smooth response contributes about
#: ``y''''(t) (L dt)^4`` to a fourth difference at spacing L (a finely sampled lag is not
#: read as noise); white noise of variance s^2 gives ``C(8, 4) s^2 = 70 s^2``.
DIFF_ORDER = 4
_COEF = np.array([(-1) ** j * comb(DIFF_ORDER, j, exact=True) for j in range(DIFF_ORDER + 1)],
                 dtype=float)
#: ``a_d = sum_j c_j c_{j+d}``: 70, -56, 28, -8, 1 (the autocovariance of the weights).
_ACOV = np.array([float(_COEF[: DIFF_ORDER + 1 - d] @ _COEF[d:]) for d in range(DIFF_ORDER + 1)])
#: Spacings (samples) of the variogram; a spacing is used when the record holds at least
#: ``8`` spans of it (``N - 4 L >= 32 L``).
NOISE_LAGS = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256)
#: The plateau is read from the largest this many spacings (AR(1) fit, see below).
FIT_LAGS = 99
#: A spacing at which more than this fraction of the differences lie beyond 3 sigma
#: (Gaussian noise: 0.27 %) shows the response, not the noise: the ladder ends before it.
MAX_EXCESS = 0.05
#: Noise makes neighbouring fourth differences (``L`` apart) anticorrelated: -0.8 for white
#: noise, -0.75 measured for AR(1) up to phi = 0.95 and on the real logs (DaISy, the rt-l
#: tank); a smooth response makes them positively correlated (+0.76 to +0.94 on a sampled
#: 1/(s+1)^4). At a correlation above -0.3 (about 2.5 sampling standard deviations from
#: -0.75 at the shortest record used) the differences read the response: the ladder ends
#: there, and a response with no rough component at all reads as noise-free.
MAX_SMOOTHNESS = -0.3
#: AR(1) coefficients searched. Noise correlated beyond ~0.95 per sample drifts like the
#: response itself over the spacings above and cannot be told from it.
_PHI = np.linspace(-0.9, 0.95, 371)
#: Truncation of the robust variance, in standard deviations (see :func:`_robust_var`).
_PHI_FINE = np.linspace(-0.99, 0.999, 4000)
_TRUNC = 3.0
_TRUNC_CONS = 1.0 - 2.0 * _TRUNC * norm.pdf(_TRUNC) / (2.0 * norm.cdf(_TRUNC) - 1.0)
_KEEP = 0.8
_KEEP_CONS = 1.0 - 2.0 * norm.ppf(0.5 + _KEEP / 2) * norm.pdf(norm.ppf(0.5 + _KEEP / 2)) / _KEEP


@dataclass(frozen=True)
class NoiseEstimate:
    """What :func:`noise_estimate` reads about the output noise of one series.

    ``sigma``: marginal standard deviation of the noise (what bands, peaks and settling
    tests compare against), at least ``resolution / sqrt(12)``. ``rho1``: lag-1
    autocorrelation (the coefficient of the fitted AR(1) model; 0 for white noise).
    ``resolution``: the detected quantisation step of the sensor (0 when the values are
    not on a grid). ``lags`` / ``variogram``: the spacings used and the robust variance of
    the fourth differences at each, divided by 70 (a white series gives ``sigma^2`` at
    every spacing; positively correlated noise rises to ``sigma^2``).
    """

    sigma: float
    rho1: float = 0.0
    resolution: float = 0.0
    lags: tuple[int, ...] = ()
    variogram: tuple[float, ...] = ()

    @property
    def correlation_samples(self) -> float:
        """Integrated correlation time in samples, ``(1 + rho1)/(1 - rho1)``: the variance
        of a mean over ``m >> 1`` samples is ``sigma^2 correlation_samples / m`` (1 for
        white noise, 9 for rho1 = 0.8). Use ``m / correlation_samples`` as the number of
        independent samples when judging a mean or a residual's whiteness."""
        return (1.0 + self.rho1) / (1.0 - self.rho1)

    @property
    def correlation_time(self) -> float:
        """The 1/e time of the autocorrelation, in samples: ``-1/ln(rho1)`` (0 when
        ``rho1 <= 0``)."""
        return -1.0 / math.log(self.rho1) if 0.0 < self.rho1 < 1.0 else 0.0


def noise_sigma(y: np.ndarray) -> float:
    """Marginal standard deviation of the noise on ``y`` (:func:`noise_estimate`)."""
    return noise_estimate(y).sigma


def noise_estimate(y: np.ndarray) -> NoiseEstimate:
    """The noise of a sampled response: marginal sigma, lag-1 autocorrelation, resolution.

    Method (a robust generalised variogram, after the difference-based estimators of
    Hall & Van Keilegom, J. R. Statist. Soc. B 65 (2003) 443-456, for regression with
    correlated errors):

    1. Fourth differences at spacing ``L``, ``D_L(i) = sum_j c_j y(i + j L)`` with
       ``c = (1, -4, 6, -4, 1)``, for the spacings :data:`NOISE_LAGS`. A smooth response
       contributes about ``y''''(t) (L dt)^4`` (nothing on a finely sampled lag); stationary
       noise of marginal variance ``s^2`` and autocorrelation ``rho`` contributes
       ``s^2 g(L)``, ``g(L) = 70 + 2 sum_{d=1}^{4} a_d rho(d L)`` (``a = -56, 28, -8, 1``).
       White noise gives ``70 s^2`` at every spacing; coloured noise is high-passed by the
       differences at ``L = 1`` (AR(1) with ``phi = 0.8`` gives only ``8.87 s^2``: the
       former estimator's 0.36 sigma) and rises to ``70 s^2`` once ``L`` exceeds its
       correlation time. That plateau is the marginal variance.
    2. The variance at each spacing is robust (:func:`_robust_var`): steps, spikes and the
       fast start of a response are large, rare differences and are truncated.
    3. Spacings are used while the variogram grows no faster than noise can: for any
       stationary noise ``g`` grows at most in proportion to ``L`` (the random-walk
       limit); a smooth response grows as ``L^8``. Growth beyond 1.5 x the spacing ratio
       ends the ladder (the response has started to show).
    4. The AR(1) model ``rho(m) = phi^m`` is fitted to the used spacings (least squares on
       the log variance; a grid over ``phi`` in [-0.9, 0.95]): ``sigma`` is the fitted
       plateau, ``rho1 = phi``. The model only bridges the gap between the largest used
       spacing and the plateau; that extrapolation is capped at a factor 2 in variance
       (``g(L_max) >= 35``), so a short record cannot inflate sigma without bound.
    5. Quantisation (:func:`resolution`): a sensor of resolution ``q`` cannot resolve
       changes below it; its rounding error is uniform with standard deviation
       ``q/sqrt(12)``, the floor of ``sigma`` (DaISy 0.244 degC, TCLab 0.32 degC).

    Accuracy (``tests/test_signal.py``, 200 seeds, 1500-sample step responses): within
    15 % of the true sigma on white noise and within 25 % on AR(1) ``phi = 0.8``; ``rho1``
    within 0.1 of ``phi``; near zero (rounding) on a noise-free response.
    """
    y = np.asarray(y, dtype=np.float64)
    q = resolution(y)
    floor = q / math.sqrt(12.0)
    n = y.size
    lags = [lag for lag in NOISE_LAGS if n - DIFF_ORDER * lag >= 8 * DIFF_ORDER * lag]
    v: list[float] = []
    for j, lag in enumerate(lags):
        d = sum(c * y[k * lag : n - (DIFF_ORDER - k) * lag] for k, c in enumerate(_COEF))
        vj, excess = _robust_var(d)
        if not vj > 0 or _smoothness(d, lag, vj) > MAX_SMOOTHNESS:
            break
        vj /= _ACOV[0]
        if j and (excess > MAX_EXCESS or vj > 1.5 * (lag / lags[j - 1]) ** 4 * v[-1]):
            break
        v.append(vj)
    used = tuple(lags[: len(v)])
    if not v or not v[0] > 0:
        return NoiseEstimate(floor, 0.0, q, used, tuple(v))
    top = np.array(used[-FIT_LAGS:], dtype=float)
    lv = np.log(np.maximum(np.array(v[-FIT_LAGS:]), v[0] * 1e-12))
    g = _g(top[None, :], _PHI[:, None])
    ok = g[:, -1] >= 0.5
    lg = np.log(g[ok])
    ls2 = np.mean(lv - lg, axis=1)
    i = int(np.argmin(np.sum((lv - lg - ls2[:, None]) ** 2, axis=1)))
    sigma = math.exp(0.5 * float(ls2[i])) if top.size > 1 else math.sqrt(v[-1])
    # the AR(1) coefficient with the same high-frequency content: g(1, rho1) = v(1)/sigma^2
    ratio = v[0] / (sigma * sigma)
    rho1 = float(_PHI_FINE[np.argmin(np.abs(_G1 - ratio))]) if used[0] == 1 else 0.0
    return NoiseEstimate(max(sigma, floor), rho1, q, used, tuple(float(x) for x in v))


def _g(lag: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """``g(L)/70`` for AR(1) noise ``rho(m) = phi^m`` (see :func:`noise_estimate`)."""
    out = np.ones(np.broadcast_shapes(lag.shape, phi.shape))
    for d in range(1, DIFF_ORDER + 1):
        out = out + 2.0 * _ACOV[d] / _ACOV[0] * np.sign(phi) ** (d * lag) * np.abs(phi) ** (d * lag)
    return out


_G1 = _g(np.array(1.0), _PHI_FINE)


def _smoothness(d: np.ndarray, lag: int, s2: float) -> float:
    """Correlation of fourth differences ``lag`` apart (clipped at 3 sigma against spikes)."""
    c = np.clip(d, -_TRUNC * math.sqrt(s2), _TRUNC * math.sqrt(s2))
    den = float(c @ c)
    return float(c[lag:] @ c[:-lag]) / den if den > 0 else 1.0


def _robust_var(d: np.ndarray) -> tuple[float, float]:
    """Variance of zero-mean differences, robust to a minority of large ones.

    Start: the mean of the smallest 80 % of ``d^2`` divided by its Gaussian expectation
    (breakdown 20 %). Then twice: the mean of ``d^2`` over ``|d| <= 3 s``, divided by
    ``E[Z^2 | |Z| <= 3] = 0.973``: unbiased for Gaussian noise and nearly as efficient as
    the plain mean square, while a step, a spike or a response's fast start (differences
    far beyond 3 s) is dropped.
    """
    d2 = d * d
    m = max(1, int(_KEEP * d2.size))
    s2 = float(np.mean(np.partition(d2, m - 1)[:m])) / _KEEP_CONS
    for _ in range(2):
        if not s2 > 0:
            return 0.0, 0.0
        keep = d2 <= _TRUNC * _TRUNC * s2
        s2 = float(np.mean(d2[keep])) / _TRUNC_CONS
    return s2, 1.0 - float(np.mean(keep))


def resolution(y: np.ndarray) -> float:
    """The quantisation step of the values of ``y``, 0 when they are not on a grid.

    On a grid when at most half the samples are distinct and every gap between
    neighbouring distinct values is within 0.2 steps of a whole number of steps (the step
    is the median of the gaps below 1.5 x the smallest: TCLab logs 0.32 and 0.33 for one
    ADC count rounded to 0.01 degC).
    """
    v = np.unique(y)
    if v.size < 3 or v.size > y.size // 2:
        return 0.0
    gaps = np.diff(v)
    q = float(np.median(gaps[gaps < 1.5 * gaps[0 if gaps.size == 1 else np.argmin(gaps)]]))
    m = gaps / q
    return q if np.mean(np.abs(m - np.round(m)) <= 0.2) >= 0.99 else 0.0


def smooth(h: np.ndarray, sigma: float, frac: float = 0.02) -> np.ndarray:
    """Savitzky-Golay smoothing (polyorder 2) over ~``frac`` of the window, only if noisy."""
    if sigma <= NOISE_FREE or h.size < 7:
        return h
    w = max(5, int(frac * h.size) | 1)
    w = min(w, (h.size - 1) | 1 if h.size % 2 == 0 else h.size)
    if w < 5:
        return h
    return savgol(h, w)


def _near(tau: np.ndarray, t: float, half: float) -> slice:
    """The samples that can lie within ``half`` of ``t`` (``tau`` increasing), with a
    margin of rounding: a local mask ``np.abs(tau[s] - t) <= half`` on them selects
    exactly what the mask on the whole window would, without a pass over all of it."""
    pad = 1e-9 * (abs(t) + abs(half)) + 1e-300
    return slice(int(np.searchsorted(tau, t - half - pad)),
                 int(np.searchsorted(tau, t + half + pad, side="right")))


#: The first crossing is searched in blocks growing from this many samples: a reading
#: near the start of a long window does not compare every sample after it.
_FIRST_BLOCK = 1024


def _first_reached(hs: np.ndarray, level: float, sgn: float, start: int) -> int | None:
    """Index of the first ``sgn * (hs - level) >= 0`` at or after ``start`` (None)."""
    lo, size = start, _FIRST_BLOCK
    while lo < hs.size:
        hi = min(hs.size, lo + size)
        above = sgn * (hs[lo:hi] - level) >= 0
        if above.any():
            return lo + int(np.argmax(above))
        lo, size = hi, 2 * size
    return None


def crossing_time(tau: np.ndarray, h: np.ndarray, level: float, sigma: float = 0.0, *,
                  start: int = 0, falling: bool = False, name: str = "",
                  hs: np.ndarray | None = None, slope: np.ndarray | None = None) -> float:
    """First time at or after index ``start`` where ``h`` reaches ``level``.

    Rising by default (``h >= level``); ``falling=True`` looks for ``h <= level``.
    Raises :class:`NotApplicable` when the level is never reached in the window.
    ``hs`` (``smooth(h, sigma)``) and ``slope`` (``np.gradient(hs, tau)``) may be given
    when they are already known (:class:`pipeline.methods.prepared.Response`).
    """
    hs = smooth(h, sigma) if hs is None else hs
    i = _first_reached(hs, level, -1.0 if falling else 1.0, start)
    if i is None:
        label = name or f"{level:.1%}"
        raise NotApplicable(f"the response never reaches {label} of its change in the window")
    if i == 0:
        return float(tau[0])
    t_c = interp_cross(tau[i - 1], tau[i], hs[i - 1], hs[i], level)
    if sigma <= NOISE_FREE:
        return t_c
    return _refine_crossing(tau, h, hs, i, t_c, level, sigma, slope)


def value_at(tau: np.ndarray, h: np.ndarray, t: float, sigma: float = 0.0,
             half: float | None = None, *, hs: np.ndarray | None = None,
             slope: np.ndarray | None = None) -> float:
    """The response ``h`` at time ``t`` (read off the graph).

    Noise-free: linear interpolation. Noisy: the centre value of a least-squares
    parabola through the raw samples in a symmetric window around ``t`` (half-width
    ``half``, by default where the smoothed response changes by about +-0.15); a
    symmetric window makes the reading unbiased up to the quartic term of the response.
    ``hs`` and ``slope`` as in :func:`crossing_time`.
    """
    if sigma <= NOISE_FREE or h.size < 7:
        return float(np.interp(t, tau, h))
    dt = float(tau[1] - tau[0])
    if half is None:
        if slope is None:
            slope = np.gradient(smooth(h, sigma) if hs is None else hs, tau)
        s_t = abs(float(np.interp(t, tau, slope)))
        half = 0.15 / s_t if s_t > 0 else 10 * dt
        half = max(half, 5 * dt)
    half = min(half, t - float(tau[0]), float(tau[-1]) - t)
    near = _near(tau, t, half)
    sel = np.abs(tau[near] - t) <= half
    if sel.sum() < 5:
        return float(np.interp(t, tau, smooth(h, sigma) if hs is None else hs))
    c2, c1, c0 = np.polyfit(tau[near][sel] - t, h[near][sel], 2)
    return float(c0)


def interp_cross(t1, t2, h1, h2, level) -> float:
    if h2 == h1:
        return float(t2)
    return float(t1 + (level - h1) * (t2 - t1) / (h2 - h1))


def _refine_crossing(tau, h, hs, i, t_c, level, sigma, slope=None) -> float:
    """Local quadratic fit of the raw samples around a preliminary crossing."""
    slope = (np.gradient(hs, tau) if slope is None else slope)[i]
    if not np.isfinite(slope) or slope == 0:
        return t_c
    # half-width: enough samples to beat the noise, short enough to stay near-quadratic
    half = min(max(0.08 / abs(slope), 3.5 * (tau[1] - tau[0])), t_c - tau[0]) if i > 0 else 0
    near = _near(tau, t_c, half)
    sel = np.abs(tau[near] - t_c) <= half
    if sel.sum() < 5:
        return t_c
    x = tau[near][sel] - t_c
    c2, c1, c0 = np.polyfit(x, h[near][sel], 2)
    roots = np.roots([c2, c1, c0 - level])
    roots = roots[np.isreal(roots)].real
    roots = roots[np.abs(roots) <= half]
    return float(t_c + roots[np.argmin(np.abs(roots))]) if roots.size else t_c


def extremum(tau: np.ndarray, h: np.ndarray, lo: int, hi: int, sigma: float,
             *, kind: str = "max", hs: np.ndarray | None = None) -> tuple[float, float, int]:
    """Peak (``kind="max"``) or valley of ``h`` in samples ``[lo, hi)``: ``(t, h, index)``.

    Noise-free: the vertex of the parabola through the extreme sample and its neighbours.
    Noisy: the vertex of a least-squares parabola over the samples within ~10 % of the
    oscillation period around the smoothed extreme. ``hs`` as in :func:`crossing_time`.
    """
    hs = smooth(h, sigma) if hs is None else hs
    seg = hs[lo:hi]
    if seg.size == 0:
        raise NotApplicable("no samples where an extremum was expected")
    j = lo + int(np.argmax(seg) if kind == "max" else np.argmin(seg))
    if sigma <= NOISE_FREE:
        if 0 < j < h.size - 1:
            x = tau[j - 1 : j + 2] - tau[j]
            c2, c1, c0 = np.polyfit(x, h[j - 1 : j + 2], 2)
            if c2 != 0:
                xv = -c1 / (2 * c2)
                if abs(xv) <= x[-1]:
                    return float(tau[j] + xv), float(c0 - c1 * c1 / (4 * c2)), j
        return float(tau[j]), float(h[j]), j
    half = max(0.1 * (tau[hi - 1] - tau[lo]), 3.5 * (tau[1] - tau[0]))
    near = _near(tau, float(tau[j]), half)
    sel = np.abs(tau[near] - tau[j]) <= half
    if sel.sum() < 5:
        return float(tau[j]), float(hs[j]), j
    x = tau[near][sel] - tau[j]
    c2, c1, c0 = np.polyfit(x, h[near][sel], 2)
    if c2 == 0 or (kind == "max") != (c2 < 0):
        return float(tau[j]), float(hs[j]), j
    xv = float(np.clip(-c1 / (2 * c2), -half, half))
    return float(tau[j] + xv), float(c2 * xv * xv + c1 * xv + c0), j


# -- Savitzky-Golay in O(N log w) --------------------------------------------------------

#: From this many taps on, :func:`savgol` convolves by overlap-add FFT instead of directly.
#: A direct convolution costs ``N w`` and ``w`` grows with the window (2 % of it), so the
#: smoothing of a long event was quadratic in its length; overlap-add costs about
#: ``N log w``. Measured (``benchmarks/methods_speed.py --crossover``, BENCHMARKS.md):
#: about equal below ~100 taps, 3x faster at 201 taps and 7-11x at 1,201 taps; the two
#: differ by rounding (below 6e-15 on a unit response). 201 taps (2 % of 10,000 samples)
#: keeps the direct path, and results identical to the bit, for every event window under
#: 10,000 samples (DaISy's and nearly all of the test suite's events).
SAVGOL_FFT_TAPS = 201


def savgol(h: np.ndarray, window: int, deriv: int = 0, delta: float = 1.0) -> np.ndarray:
    """``scipy.signal.savgol_filter(h, window, 2, deriv, delta)`` (mode "interp"), in
    ``O(N log window)`` for long windows.

    The interior is the convolution of ``h`` with :func:`scipy.signal.savgol_coeffs`
    (:func:`scipy.signal.oaconvolve`); the first and last ``window // 2`` values are, as
    in ``savgol_filter``'s mode "interp", the quadratic least-squares fits of the first
    and last ``window`` samples (:func:`numpy.polyfit`) and their derivative, evaluated
    there (``savgol_filter`` on the edge samples alone would convolve them too, ``w^2``)."""
    if window < SAVGOL_FFT_TAPS or h.size < 2 * window:
        return savgol_filter(h, window, 2, deriv=deriv, delta=delta)
    out = oaconvolve(h, savgol_coeffs(window, 2, deriv=deriv, delta=delta, use="conv"),
                     mode="same")
    half = window // 2
    k = np.arange(window, dtype=np.float64)
    for edge, at in ((slice(0, window), slice(0, half)),
                     (slice(h.size - window, h.size), slice(window - half, window))):
        p = np.polyder(np.polyfit(k, h[edge], 2), deriv)
        out[edge][at] = np.polyval(p, k[at]) / delta**deriv
    return out
