"""Two exchangeable lags the data cannot tell apart (pipeline.refine.coincident): their
intervals bounded by the data, not 1e300 wide, over fixed seeds of a plant whose two
lags are equal (K 1, T1 = T2 = 6 s, delay 2 s) and of a plant whose lags differ."""

import math

import numpy as np

from pipeline.models import ProcessModel
from pipeline.refine import refine
from pipeline.synth.plants import response


def _step_fit(T1: float, T2: float, seed: int, sigma: float = 0.01):
    t = np.arange(0.0, 80.0, 0.5)
    u = np.where(t >= 10.0, 1.0, 0.0)
    truth = ProcessModel("two_lags", {"K": 1.0, "T1": T1, "T2": T2, "delay": 2.0})
    y = response(truth, t, u, 0.0, 3.0, noise=sigma, seed=seed)
    return refine(t, u, y, "two_lags", u_ref=0.0,
                  starts=[{"T1": 8.0, "T2": 3.0, "delay": 1.0}])


def test_equal_lags_have_bounded_intervals_and_coincident_ones_cover():
    """Every seed's lag intervals are bounded (1e300 wide before, where the fit put the
    lags together); where the lags coincide the intervals cover the truth. Where noise
    split them (7.2 s and 4.6 s) the plain linearisation holds the split to be real and
    its T1 interval can miss 6 s (2 of 8 seeds): left open in issue 27's note."""
    coincident = 0
    for seed in range(8):
        ref = _step_fit(6.0, 6.0, seed)
        for name in ("T1", "T2"):
            lo, hi = ref.ci95[name]
            assert math.isfinite(lo) and math.isfinite(hi) and hi / lo < 10.0, (name, lo, hi)
            if ref.diagnostics["coincident_lags"]:
                assert lo <= 6.0 <= hi, (seed, name, lo, hi)
        coincident += ref.diagnostics["coincident_lags"]
        assert ref.ci95["K"][0] <= 1.0 <= ref.ci95["K"][1]
    assert coincident >= 2


def test_distinct_lags_keep_the_plain_linearisation():
    ref = _step_fit(10.0, 2.0, 0)
    assert not ref.diagnostics["coincident_lags"]
    assert ref.ci95["T1"][0] <= 10.0 <= ref.ci95["T1"][1]
    assert ref.ci95["T2"][0] <= 2.0 <= ref.ci95["T2"][1]
