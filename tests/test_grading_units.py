"""The pieces the verdicts and the recommendation are built of, each on a case with a
known answer: the info severity, a refinement's response band from its covariance, the
likelihood-ratio test of a simpler structure, the interval's wording, the grid rule."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.fit import Fit, Flag, ParameterCovariance, RefinementSummary
from pipeline.grading.determinacy import response_band
from pipeline.grading.recommendation import earns_parameters
from pipeline.grading.verdicts import verdict_of
from pipeline.models import ProcessModel
from pipeline.record import uniform_step
from pipeline.report.tables import interval_text, with_ci


def test_info_flags_do_not_change_the_verdict():
    info, warn = Flag("unsettled", "m", severity="info"), Flag("poor_fit", "m")
    assert verdict_of([info]) == "ok" and verdict_of([info, warn]) == "warning"


def _refined(model: ProcessModel, cov: ParameterCovariance) -> Fit:
    summary = RefinementSummary("rest", 0.0, 0.0, 1e-4, 500, 500.0, 1.0, 4, {}, 10, 1, "j",
                                covariance=cov)
    return Fit("lsq_first_order", 0, "ok", model=model, refinement=summary)


def test_covariance_draws_have_the_covariance_and_the_band_its_width():
    """T on log scale with sigma 0.1 (10 %), K with sigma 0.02 (1 %): the draws reproduce
    the covariance, and the response band of K/(Ts+1) over 5 T is the delta method's:
    ``1.96 sqrt((1 - e^-x)^2 0.01^2 + (x e^-x)^2 0.1^2)`` at its largest (x near 1, where
    the lag matters most)."""
    model = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 0.0})
    cov = ParameterCovariance(("T", "K"), (True, False), (1.0, 1.0), (math.log(10.0), 2.0),
                              ((0.01, 0.0), (0.0, 0.0004)))
    draws = cov.draws(4000, seed=1)
    logs = np.array([[math.log(d["T"]), d["K"]] for d in draws])
    assert np.cov(logs.T) == pytest.approx(np.array(cov.matrix), rel=0.1, abs=1.2e-4)
    assert cov.draws(3, seed=1) == cov.draws(3, seed=1)  # fixed seed: the same draws
    band = response_band(_refined(model, cov), 50.0)
    x = np.linspace(0.0, 5.0, 501)
    delta = 1.96 * np.sqrt((1 - np.exp(-x)) ** 2 * 1e-4 + (x * np.exp(-x)) ** 2 * 1e-2)
    assert band == pytest.approx(float(delta.max()), rel=0.15)
    bad = ParameterCovariance(("T", "K"), (True, False), (1.0, 1.0), (2.3, 2.0),
                              ((math.nan, 0.0), (0.0, 1.0)))
    assert response_band(_refined(model, bad), 50.0) == math.inf


def test_a_simpler_structure_that_fits_worse_loses_to_the_one_that_earns_its_parameters():
    """AIC = n_eff ln(SSE/n) + 2k; one parameter more and an AIC 10 lower is a likelihood
    ratio of 12 > 3.84 (chi-square, 1 dof, 95 %); an AIC 1 lower is 3 < 3.84."""
    m1 = ProcessModel("first_order", {"K": 1.0, "T": 1.0})
    m2 = ProcessModel("two_lags", {"K": 1.0, "T1": 1.0, "T2": 0.5})

    def fit(model, aic, events=()):
        return Fit("x", 0, "ok", model=model, metrics={"aic": aic}, events=events)

    assert earns_parameters(fit(m2, -110.0), fit(m1, -100.0))
    assert not earns_parameters(fit(m2, -101.0), fit(m1, -100.0))
    assert not earns_parameters(fit(m1, -200.0), fit(m2, -100.0))  # not more parameters
    assert not earns_parameters(fit(m2, -110.0, (0, 1)), fit(m1, -100.0))  # not one event


def test_an_interval_reads_as_a_half_width_rounded_to_it_or_as_its_ends():
    model = ProcessModel("first_order", {"K": 21.2234, "T": 58.61, "delay": 0.0})
    fit = Fit("x", 0, "ok", model=model, ci95={"K": (20.69, 21.75), "T": (46.6, 70.6)})
    assert with_ci(fit, "K") == "21.22 ± 0.53" and with_ci(fit, "T") == "59 ± 12"
    lopsided = Fit("x", 0, "ok", model=model, ci95={"T": (30.0, 200.0)})
    assert with_ci(lopsided, "T") == "58.61 [30, 200]"
    # the interval's ends to the same place as the value (issue 27 item 9)
    assert interval_text(58.61, 46.54, 70.68) == "[47, 71]"
    assert interval_text(21.2234, 20.69, 21.75) == "[20.69, 21.75]"
    assert interval_text(2.0, 1.99988, 2.00012) == "[1.99988, 2.00012]"  # not [2, 2]
    assert interval_text(58.61, 30.0, 200.0) == "[30, 200]"


def test_one_grid_rule_the_mean_interval():
    t = np.arange(1001) * 0.01  # float jitter of a few ulps: uniform
    assert uniform_step(t) == pytest.approx(0.01, rel=1e-12)
    jitter = t + np.r_[0.0, np.full(999, 2e-6), 0.0]  # 0.02 % of the step: irregular at 1e-6
    assert uniform_step(jitter) is None and uniform_step(jitter, 1e-3) == pytest.approx(0.01)
