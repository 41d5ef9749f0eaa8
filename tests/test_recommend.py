"""The recommended model: the lowest held-out error, the simpler structure within the
uncertainty, an information criterion with one event; a pure function of a result."""

import copy
from dataclasses import replace

import numpy as np
import pytest

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.grading.recommendation import (
    Candidate,
    criterion,
    held_out,
    paired_difference,
    recommend,
)
from pipeline.models import ProcessModel
from pipeline.synth import step_record
from pipeline.validate import score
from tests.test_refine import _staircase_record

LSQ = ("lsq_first_order", "lsq_second_order", "lsq_two_lags", "lsq_n_lags")
FOPDT = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 2.0})
TWO_LAGS = ProcessModel("two_lags", {"K": 1.5, "T1": 10.0, "T2": 3.0, "delay": 1.0})

#: model selection only (the tuning of the recommended model is tested in test_tuning*)
ONLY_MODELS = AnalysisOptions(tuning=None)


def _two_steps(truth, seed, noise, t_end=200.0):
    return step_record(truth, u0=2.0, changes=[(20.0, 5.0), (100.0, 3.0)], t_end=t_end,
                       dt=0.5, y0=7.0, noise=noise, seed=seed)


def test_the_simpler_structure_stays_on_fresh_noise():
    """A first-order plant: the two-lag, second-order and equal-lag fits nest it and
    validate about as well; the first-order structure is recommended on every night."""
    chosen = []
    for seed in range(20):
        res = analyse(_two_steps(FOPDT, seed, 0.06), AnalysisOptions(tuning=None, methods=LSQ))
        chosen.append(res.recommended.model.structure)
    assert chosen.count("first_order") >= 19


def test_a_far_worse_model_is_never_as_good():
    """An underdamped plant: the first-order fit misses the oscillation (tens of times the
    noise variance); its errors are one long correlated pattern, yet the difference is
    many standard errors."""
    truth = ProcessModel("second_order", {"K": 0.8, "zeta": 0.3, "wn": 1.0})
    rec = step_record(truth, u0=2.0, changes=[(6.6, 5.0), (33.0, 3.0)], t_end=60.0, dt=0.1,
                      y0=7.0, noise=0.024, seed=3)
    res = analyse(rec, AnalysisOptions(tuning=None,
                                       methods=("lsq_first_order", "lsq_second_order")))
    assert res.recommendation.method == "lsq_second_order"
    assert res.recommendation.reason.startswith("lowest validation MSE")
    c, b = (Candidate(f, f.metrics["mse_validation"], *held_out(f, res))
            for f in (res.fit("lsq_first_order", 0), res.fit("lsq_second_order", 0)))
    diff, se = paired_difference(c, b, np.mean([e.noise**2 for e in res.events]))
    assert c.error > 20 * b.error and diff > 20 * se


def test_one_event_is_decided_by_the_information_criterion():
    for truth, expected in ((TWO_LAGS, {"two_lags", "second_order"}),
                            (FOPDT, {"first_order"})):
        rec = step_record(truth, u0=2.0, changes=[(20.0, 5.0)], t_end=150.0, dt=0.5, y0=7.0,
                          noise=0.01 * truth.K * 3, seed=5)
        res = analyse(rec, ONLY_MODELS)
        assert criterion(res) == "aic"
        assert res.recommended.model.structure in expected
        assert "AIC" in res.recommendation.reason and "nothing was held out" in \
            res.recommendation.reason


def test_every_event_identifying_is_decided_by_the_held_out_error():
    res = analyse(_staircase_record(7), AnalysisOptions(tuning=None, events="all"))
    assert criterion(res) == "mse_cross_validation"
    rec_fit = res.recommended
    assert rec_fit is not None and rec_fit.model.structure == "first_order"
    assert "held-out MSE" in res.recommendation.reason
    assert rec_fit.metrics["mse_cross_validation"] == pytest.approx(0.03**2, rel=0.3)


def test_a_pure_function_of_the_result():
    res = analyse(_two_steps(TWO_LAGS, 1, 0.045), ONLY_MODELS)
    before = copy.deepcopy(res.fits)
    first, again = recommend(res), recommend(res)
    assert first == again == res.recommendation
    assert [f.model for f in res.fits] == [f.model for f in before]
    graphical = replace(res, fits=[f for f in res.fits if not f.method.startswith("lsq_")])
    r = recommend(graphical)
    assert r is not None and not r.method.startswith("lsq_")
    assert recommend(replace(res, fits=[])) is None


def test_a_graphical_model_stands_for_its_structure_when_the_refinement_missed():
    """A refinement that missed (its model replaced by one with a 50 % too long time
    constant) validates far worse than a graphical reading of the same structure, which
    then represents the structure."""
    rec = _two_steps(FOPDT, 2, 0.06)
    res = analyse(rec, AnalysisOptions(tuning=None, methods=("first_order", "viteckova1",
                                                "lsq_first_order")))
    lsq = res.fit("lsq_first_order", 0)
    bad = ProcessModel("first_order", {**lsq.model.params, "T": 15.0})
    bad_fit = replace(lsq, model=bad, metrics=score(bad, rec, res.events, res.events[0], [1]))
    broken = replace(res, fits=[bad_fit if f is lsq else f for f in res.fits])
    assert recommend(res).method == "lsq_first_order"
    assert recommend(broken).method in ("first_order", "viteckova1")
