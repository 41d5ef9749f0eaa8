"""A one-event refinement's intervals widened by the noise its held-out events show.

The Jacobian covariance of :mod:`pipeline.uncertainty` reads the noise off the fit's own
residuals. Those have lost whatever part of the noise the model could absorb: a wander
slower than the window passes for the offset, the gain and a slower lag, so under 1/f
noise the residuals look nearly white and the gain's interval is about 2.4x too narrow
in standard deviation (issue 27 item 8: K covered in 58 % of 120 fits, median squared
standardised error 2.68 against 0.45). No estimate from those residuals can see it: the
estimate's sensitivity rows lie in the Jacobian's column space, to which the residuals
are orthogonal (a Newey-West estimate from them made the intervals narrower still).

The held-out events' residuals (the model simulated on them as validation,
:func:`pipeline.validate.heldout_residuals`) were not fitted, so their autocovariance
keeps the slow part. The covariance of the estimates is then the sandwich

    C = A Gamma A^T

with ``A`` the profiled pseudo-inverse of the refinement (``(J^T J)^+ J^T`` over its
criterion rows, :class:`pipeline.fit.RowSensitivity`) and ``Gamma`` the rows' noise
covariance, Toeplitz of the held-out autocovariance (the autocorrelation-consistent
covariance of least squares, W. K. Newey, K. D. West, "A simple, positive semi-definite,
heteroskedasticity and autocorrelation consistent covariance matrix", Econometrica
55(3):703-708, 1987, here with the noise's autocovariance from data the fit did not
absorb, over as many lags as the fit has rows). Where the rows are block means of ``c`` samples, the
held-out residuals are summed in blocks of ``c`` the same way first. Each variance is
kept at least the fit's own (the floor where the held-out stretch is short or quiet),
and the fit's own covariance is kept beside (``covariance_fit``): the held-out misfit
check must not be judged against a spread that the misfit itself widened.

Only a one-event fit is widened. A fit over several events would read its
cross-validation folds' residuals, which hold each fold model's own error, step-shaped
like the gain's sensitivity: under white noise that widened the gain's interval by a
median 1.38 in standard deviation where it covered the truth already (BENCHMARKS.md).

Measured (``python benchmarks/interval_coverage.py --seeds 30``, 600 gain intervals per
noise colour, BENCHMARKS.md): the gain covered under 1/f noise in 73.2 % before, 93.2 %
after (AR(1) 94.8 % to 97.8 %, white 95.8 % to 99.0 %); with the generator's own
covariance in the sandwich (an oracle) 93 % on a smaller set.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..events import Event
from ..fit import Fit, ParameterCovariance
from .coincident import from_symmetric
from .event import JACOBIAN_INTERVALS
from .refinement import intervals

#: Held-out rows (samples, or blocks of as many as a criterion row holds) at least for an
#: autocovariance to widen by.
MIN_HELDOUT = 32

#: A model whose RMS misfit is this many noise sigmas off explains the data structurally
#: wrong (with the right structure the misfit is the noise: ratio ~1); below it held-out
#: residuals are read as noise (:func:`noise_bar`; ``validation_misfit`` flags beyond).
MISFIT_RATIO = 3.0

#: How the intervals were made when the held-out residuals widened them.
WIDENED_INTERVALS = ("Jacobian, scaled by the residuals' effective sample size, widened by "
                     "the held-out residuals' autocovariance")


def own_rms(fit: Fit) -> float:
    """The RMS error of a fit on its own identification data: a refinement's fit error
    (its offset and state estimated), else the reading simulated on its event."""
    mse = fit.refinement.mse_fit if fit.is_refined else fit.metrics.get(
        "mse_identification", math.nan)
    return math.sqrt(mse) if math.isfinite(mse) and mse >= 0 else math.nan


def noise_bar(fit: Fit, held: list[Event]) -> float:
    """The held-out RMS error that noise can explain for ``fit``: :data:`MISFIT_RATIO`
    times the larger of the held-out events' mean noise and the fit's own error
    (``validation_misfit``'s first bar, :mod:`pipeline.grading.heldout`, before the best
    refinement's floor, which needs every fit). :func:`widened` reads held-out residuals
    beyond it as misfit, not noise."""
    noise = float(np.mean([e.noise for e in held])) if held else 0.0
    own = own_rms(fit)
    return MISFIT_RATIO * max(noise, own if math.isfinite(own) else 0.0)


def heldout_autocovariance(idx: np.ndarray, e: np.ndarray, samples: int, lags: int
                           ) -> np.ndarray | None:
    """The autocovariance, lags ``0 .. lags - 1``, of the held-out residuals ``e`` (at the
    record's samples ``idx``) summed in blocks of ``samples`` consecutive samples over
    ``sqrt(samples)`` (a refinement's criterion rows), each contiguous run's mean removed,
    the lag products pooled over runs and divided by the rows in all (the biased
    estimator: positive semi-definite); None when too few or not finite."""
    idx, e = np.asarray(idx), np.asarray(e, np.float64)
    if e.size < MIN_HELDOUT * samples or not np.all(np.isfinite(e)):
        return None
    cuts = np.flatnonzero(np.diff(idx) != 1) + 1
    acov = np.zeros(lags)
    rows = 0
    for run in np.split(e, cuts):
        m = run.size // samples
        if m < 2:
            continue
        x = run[: m * samples].reshape(m, samples).sum(axis=1) / math.sqrt(samples)
        x = x - x.mean()
        k = min(lags, m)
        size = 1 << int(math.ceil(math.log2(m + k)))
        f = np.fft.rfft(x, size)
        acov[:k] += np.fft.irfft(f * np.conj(f), size)[:k]
        rows += m
    if rows < MIN_HELDOUT or not acov[0] > 0:
        return None
    return acov / rows


def sandwich(rows: np.ndarray, acov: np.ndarray) -> np.ndarray:
    """``A Gamma A^T`` for the sensitivity rows ``A`` (p x n) and the n x n Toeplitz
    ``Gamma`` of ``acov`` (lags beyond it zero): each row's product with ``Gamma`` by a
    circulant embedding (FFTs of ``2 n``). With :func:`heldout_autocovariance`'s biased
    estimate ``Gamma`` is a principal block of a positive semi-definite Toeplitz matrix,
    so no lag window is needed: a Bartlett window over the fit's rows covered the gain
    under 1/f noise in 89.8 % of 600 fits, none in 93.2 % (BENCHMARKS.md)."""
    p, n = rows.shape
    g = np.zeros(n)
    k = min(n, acov.size)
    g[:k] = acov[:k]
    size = 1 << int(math.ceil(math.log2(2 * n)))
    c = np.zeros(size)
    c[:n] = g
    c[size - n + 1:] = g[1:][::-1]
    gamma_a = np.fft.irfft(np.fft.rfft(c)[None, :] * np.fft.rfft(rows, size, axis=1), size,
                           axis=1)[:, :n]
    out = rows @ gamma_a.T
    return (out + out.T) / 2.0


def widened(fit: Fit, idx: np.ndarray, e: np.ndarray, noise_rms: float) -> Fit:
    """``fit`` with its intervals, standard errors and covariance from the sandwich of its
    held-out residuals ``e`` (see the module docstring), each variance at least the fit's
    own; the fit itself where it has no sensitivity rows, the residuals do not give an
    autocovariance, or their RMS is beyond ``noise_rms``: what noise can explain
    (:func:`noise_bar`, the held-out misfit check's first bar).
    Beyond it the held-out residuals are the model's misfit, not noise (a gain that
    changes with the operating point), which ``validation_misfit`` names; the intervals
    then say what the fit's own event determines. The transient sensitivity is dropped
    either way; bootstrap intervals are kept as they are."""
    ref = fit.refinement
    if ref is None or ref.sensitivity is None:
        return fit
    sens, cov = ref.sensitivity, ref.covariance
    plain = replace(fit, refinement=replace(ref, sensitivity=None))
    if cov is None or ref.interval_method != JACOBIAN_INTERVALS or not e.size \
            or not float(np.sqrt(np.mean(e * e))) <= noise_rms:
        return plain
    acov = heldout_autocovariance(idx, e, max(sens.samples, 1), sens.rows.shape[1])
    if acov is None:
        return plain
    own = np.asarray(cov.matrix, np.float64)
    sand = sandwich(sens.rows, acov)
    if sens.pair is not None:  # rows of two coincident lags in (m, w)
        sand = from_symmetric(sand, np.asarray(cov.z), sens.pair, sens.quantile)
    d_own, d_sand = np.diag(own), np.diag(sand)
    if not (np.all(np.isfinite(sand)) and np.all(d_sand > 0)) or np.all(d_sand <= d_own):
        return plain
    scale = np.sqrt(np.maximum(1.0, d_own / d_sand))
    matrix = sand * np.outer(scale, scale)
    new = ParameterCovariance(cov.names, cov.log, cov.scale, cov.z,
                              tuple(tuple(map(float, row)) for row in matrix))
    ci, std = intervals(fit.model.structure, new, fit.model.params, sens.quantile)
    return replace(fit, ci95=ci, refinement=replace(
        ref, std=std, covariance=new, covariance_fit=cov, sensitivity=None,
        interval_method=WIDENED_INTERVALS))
