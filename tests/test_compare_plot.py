"""The report's "compare" view (issue 29): the recommended model simulated over every
event, its fit % as MATLAB's ``compare`` computes it, and the residuals' autocorrelation
with the band of white noise; first in a full report, left out of a summary one."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pipeline
from pipeline.report.plots import ACF_SAMPLES, is_heavy, residual_acf
from pipeline.report.sections import compare_curve, record_section
from pipeline.simulation import simulate

TRUTH = pipeline.ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 2.0})


def _log(sigma: float, seed: int = 0):
    t = np.arange(0.0, 400.0, 0.5)
    u = 1.0 + 0.5 * ((t >= 50) & (t < 150)) + 1.0 * ((t >= 250) & (t < 330))
    y = simulate(TRUTH, t, u, 1.0, 4.0)
    return t, u, y + np.random.default_rng(seed).normal(0.0, sigma, t.size)


def test_a_noise_free_log_fits_to_100_percent():
    res = pipeline.identify(*_log(0.0))
    sl, yhat, fit = compare_curve(res)
    assert fit == pytest.approx(100.0, abs=0.5)
    # the curve covers the events, where the validation simulates them
    first, last = res.events[0], res.events[-1]
    assert sl.start <= first.i_start and sl.stop >= last.i_end
    assert np.max(np.abs(yhat - res.record.y[sl])) < 0.01


def test_fit_percent_is_the_nrmse_fit_and_noise_lowers_it():
    res = pipeline.identify(*_log(0.05, seed=3))
    sl, yhat, fit = compare_curve(res)
    y = res.record.y[sl]
    ok = np.isfinite(yhat)
    expected = 100 * (1 - np.linalg.norm(y[ok] - yhat[ok]) / np.linalg.norm(y[ok] - y[ok].mean()))
    assert fit == pytest.approx(expected)
    assert 80.0 < fit < 99.0
    # the right model leaves white residuals: their autocorrelation within the band
    acf = residual_acf(y - yhat)
    band = 1.96 / math.sqrt(np.count_nonzero(ok))
    assert acf[0] == 1.0 and np.mean(np.abs(acf[1:]) <= band) >= 0.9


def test_residual_acf_reads_an_ar1_and_caps_its_samples():
    e = np.zeros(5000)
    rng = np.random.default_rng(1)
    for k in range(1, e.size):
        e[k] = 0.8 * e[k - 1] + rng.normal()
    acf = residual_acf(e, lags=5)
    assert acf[1:4] == pytest.approx([0.8, 0.64, 0.512], abs=0.05)
    assert ACF_SAMPLES <= 1_000_000
    assert residual_acf(np.full(10, 3.0), lags=3).tolist() == [1.0, 0.0, 0.0, 0.0]


def test_compare_comes_first_in_a_full_report_only():
    res = pipeline.identify(*_log(0.02))
    ctx, files = record_section(res, "full", "r0")
    assert ctx["compare"] is not None and "r0_compare.png" in "".join(files)
    ctx, files = record_section(res, "summary", "r0")
    assert ctx["compare"] is None and not any("compare" in f for f in files)


def test_the_recommended_curve_is_the_heavy_one_by_its_label():
    assert is_heavy("lsq_first_order: 2/(10s+1)", "lsq_first_order")
    assert is_heavy("lsq_first_order (MSE 0.01)", "lsq_first_order")
    assert not is_heavy("lsq_first_order_x: 2/(10s+1)", "lsq_first_order")
    assert not is_heavy("first_order: 2/(10s+1)", "lsq_first_order")
    assert not is_heavy("first_order", None)


def test_only_the_recommended_fits_own_event_draws_it_heavy():
    """The review's case: a label does not name the event, so the same method's fit on
    another event was drawn heavy there too."""
    from pipeline.analysis import AnalysisOptions, analyse
    from pipeline.report.sections import _heavy
    from pipeline.synth.montecarlo import PLANTS, Condition, mc_record

    res = analyse(mc_record(PLANTS["fopdt_delay0.5"], Condition(), 0),
                  AnalysisOptions(events="all"))
    rec = res.recommended
    assert _heavy(res, rec.event) == rec.method or _heavy(res, rec.event).startswith(
        rec.method)
    others = [i for i in res.identification_events if i != rec.event]
    assert others and all(_heavy(res, i) is None for i in others)
