"""Every recommended model carries intervals where a refinement is left (issue 27 item 1).

A graphical reading has no intervals. On these Monte Carlo records (fixed seeds, known
truth) a reading validated better than the refinement and was recommended, off the
truth's step response by more than 3 %, while the refinement the tool had fitted to the
same event was right. The reading is now a candidate only where the refinement of its
structure missed on their event (it fits the event worse than the reading) or no
refinement is left; the twin, a refinement that missed, is
``tests/test_recommend.py::test_a_graphical_model_stands_for_its_structure_when_the_refinement_missed``.
"""

import math

import pytest

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.synth.montecarlo import PLANTS, Condition, mc_record, score

#: (plant, noise colour, level, window in time scales, seed): records where a wrong
#: reading was recommended (measured at 8292819, `benchmarks/verdict_calibration.py`).
CASES = [
    ("fopdt_delay0.05", "pink", 0.02, 6.0, 0),
    ("lags_3", "ar1", 0.02, 3.0, 1),
    ("lags_6", "pink", 0.02, 3.0, 2),
    ("two_lags_equal", "ar1", 0.02, 3.0, 1),
    ("lags_6", "ar1", 0.02, 3.0, 1),  # measured at f4f4917
]


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"{c[0]}-{c[1]}-s{c[4]}")
def test_the_refinement_not_the_reading_that_validated_best(case):
    name, kind, level, window, seed = case
    plant, cond = PLANTS[name], Condition(kind, level, window)
    res = analyse(mc_record(plant, cond, seed), AnalysisOptions(tuning=None))
    fit = res.recommended
    assert fit is not None and fit.is_refined
    assert set(fit.ci95) >= {"K"} and all(math.isfinite(v) for v in fit.ci95["K"])
    assert score(fit.model, plant, cond).right
    # a reading validated better than the answer and is wrong: the rule, not the noise,
    # made the choice
    readings = [f for f in res.fits if f.ok and not f.is_refined and math.isfinite(
        f.metrics.get("mse_validation", math.nan))]
    best = min(readings, key=lambda f: f.metrics["mse_validation"])
    assert best.metrics["mse_validation"] < fit.metrics["mse_validation"]
    assert not score(best.model, plant, cond).right


def test_a_reading_stays_where_its_structure_was_not_refined():
    """The twin of the rule: a two-lag plant analysed with only a first-order refinement
    beside the readings. Harriott's two-lag reading (validation MSE 1.3e-4) has no
    refinement of its structure to defer to and is recommended, not the first-order
    refinement 6 times worse."""
    from pipeline.models import ProcessModel
    from pipeline.synth.plants import step_record

    truth = ProcessModel("two_lags", {"K": 2.0, "T1": 10.0, "T2": 6.0, "delay": 1.0})
    rec = step_record(truth, u0=0.0, y0=0.0, changes=[(10.0, 1.0), (150.0, 0.0)], dt=0.2,
                      t_end=300.0, noise=0.01, seed=1)
    res = analyse(rec, AnalysisOptions(methods=("harriott", "smith", "first_order",
                                                "lsq_first_order"), tuning=None))
    assert res.recommended.method == "harriott"
    lsq = res.fit("lsq_first_order", 0)
    assert lsq.metrics["mse_validation"] > 5 * res.recommended.metrics["mse_validation"]


@pytest.mark.parametrize("seed_kind", [(3, "white"), (4, "ar1")], ids=str)
def test_a_reading_without_intervals_sets_no_undetermined_refinement_aside(seed_kind):
    """Six lags, 2 % noise, windows of 3 T: every refinement that fits within the noise
    has a wide interval. A reading has no interval to show it is wide, and it counted as
    determined, so the refinements were set aside and a reading 9 % (white, seed 3) and
    3.2 % (AR(1), seed 4) off was recommended (at f4f4917). A reading sets nothing aside
    now: the recommendation is the n-lag refinement, with intervals, and right."""
    from pipeline.grading.recommendation import fits_within_noise, undetermined

    seed, kind = seed_kind
    plant, cond = PLANTS["lags_6"], Condition(kind, 0.02, 3.0)
    res = analyse(mc_record(plant, cond, seed), AnalysisOptions(tuning=None))
    fit = res.recommended
    assert fit is not None and fit.is_refined and undetermined(fit)
    assert score(fit.model, plant, cond).right
    ok = [f for f in res.fits if f.ok and f.verdict != "unreliable"]
    assert not [f for f in ok if f.is_refined and not undetermined(f) and fits_within_noise(f)]
    assert [f for f in ok if not f.is_refined and fits_within_noise(f)]  # the old answer
