"""A fit over several events, its intervals widened by its folds' spread (issue 27 item 8;
:mod:`pipeline.refine.fold_spread`): the jackknife against its formula, the test's two
sides, and over fixed seeds the gain's coverage under 1/f noise with its white-noise twin."""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.fit import Fit, Fold, ParameterCovariance, RefinementSummary
from pipeline.models import ProcessModel
from pipeline.refine.event import JACOBIAN_INTERVALS
from pipeline.refine.fold_spread import FOLD_INTERVALS, fold_covariance, widened_by_folds
from pipeline.synth.montecarlo import PLANTS, Condition, mc_record
from pipeline.uncertainty import t_quantile

Q = 1.97  # a joint fit's t quantile (hundreds of effective samples)


def _fit(K_folds, T_folds, sd_K=0.01, sd_logT=0.01):
    cov = ParameterCovariance(("T", "delay", "K"), (True, True, False), (1.0, 1.0, 1.0),
                              (math.log(10.0), math.log(1.0), 2.0),
                              ((sd_logT**2, 0, 0), (0, 1e-4, 0), (0, 0, sd_K**2)))
    folds = tuple(Fold((i,), {"K": k, "T": t, "delay": 1.0}, None, 0.1, "exact")
                  for i, (k, t) in enumerate(zip(K_folds, T_folds, strict=True)))
    ref = RefinementSummary(state="rest", y0=0.0, u0=0.0, mse_fit=0.01, n_fit=500,
                            n_eff=400.0, variance_factor=1.25, n_params=5,
                            std={"K": sd_K, "T": 10 * sd_logT, "delay": 0.01}, nfev=10,
                            runs=1, interval_method=JACOBIAN_INTERVALS, covariance=cov,
                            folds=folds)
    model = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 1.0})
    ci = {"K": (2.0 - Q * sd_K, 2.0 + Q * sd_K)}
    return Fit("lsq_first_order", 0, "ok", None, model, {}, ci95=ci, events=(0, 1, 2, 3),
               refinement=ref)


def test_the_jackknife_is_its_formula():
    fit = _fit([1.9, 2.0, 2.1, 2.0], [9.0, 10.0, 11.0, 10.0])
    jack = fold_covariance(fit.refinement.covariance, [dict(f.params) for f in
                                                       fit.refinement.folds])
    K = np.array([1.9, 2.0, 2.1, 2.0])
    logT = np.log([9.0, 10.0, 11.0, 10.0])
    assert jack[2, 2] == pytest.approx(3 / 4 * np.sum((K - K.mean()) ** 2))
    assert jack[0, 0] == pytest.approx(3 / 4 * np.sum((logT - logT.mean()) ** 2))
    assert jack[1, 1] == 0.0  # the folds agree on the delay


def test_folds_that_disagree_widen_to_t_jackknife_errors():
    fit = widened_by_folds(_fit([1.9, 2.0, 2.1, 2.0], [10.0, 10.0, 10.0, 10.01]), Q)
    sd_jack = math.sqrt(3 / 4 * 0.02)
    lo, hi = fit.ci95["K"]
    assert (hi - lo) / 2 == pytest.approx(t_quantile(3) * sd_jack, rel=1e-9)
    assert fit.refinement.interval_method == FOLD_INTERVALS
    assert fit.refinement.covariance_fit is not None  # the fit's own, for the misfit check
    assert fit.refinement.std["T"] == pytest.approx(0.1, rel=1e-6)  # T's folds agree


def test_folds_that_agree_leave_the_fit_as_it_is():
    fit = _fit([1.99, 2.0, 2.01, 2.0], [9.9, 10.0, 10.1, 10.0])
    assert widened_by_folds(fit, Q) is fit
    two = _fit([1.0, 3.0], [10.0, 10.0])  # one degree of freedom: no test
    assert widened_by_folds(two, Q) is two


def _coverage(args):
    kind, seed = args
    plant = PLANTS["fopdt_delay0.5"]
    rec = mc_record(plant, Condition(kind, 0.02, 3.0), seed)
    res = analyse(rec, AnalysisOptions(methods=("lsq_first_order",), consistency=False,
                                       tuning=None, events="all"))
    fit = next(f for f in res.fits if f.ok and f.events)
    lo, hi = fit.ci95["K"]
    ref = fit.refinement
    own = ref.covariance_fit or ref.covariance
    sd_own = math.sqrt(own.matrix[own.names.index("K")][own.names.index("K")])
    q = (hi - lo) / 2 / ref.std["K"]
    return (lo <= 2.0 <= hi, abs(fit.model.params["K"] - 2.0) <= q * sd_own,
            ref.interval_method == FOLD_INTERVALS)


def test_the_gain_covered_under_pink_noise_and_white_noise_left_alone():
    """20 seeds of a first-order plant (K 2, T 10 s, delay 5 s), 2 % noise, 3 T windows,
    the joint fit over its five events. Measured: under 1/f noise the fit's own interval
    covers K in 15 of 20, the widened one in 19 (14 widened); under white noise 20 of 20
    either way, 10 widened (a third to a half: the jackknife of four folds is noisy)."""
    seeds = range(20)
    with ProcessPoolExecutor(2) as pool:
        pink = list(pool.map(_coverage, [("pink", s) for s in seeds]))
        white = list(pool.map(_coverage, [("white", s) for s in seeds]))
    assert sum(c for c, _, _ in pink) >= 18
    assert sum(c for c, _, _ in pink) > sum(c for _, c, _ in pink)  # the widening did it
    assert sum(c for c, _, _ in white) >= 19
    assert sum(w for _, _, w in white) <= 12
