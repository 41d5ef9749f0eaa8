"""A model whose own event a richer refinement fits significantly better does not "fit
within the noise" (issue 27 item 1, the likelihood-ratio half), over fixed seeds.

Before it, on a zero + two lags plant (K 1, Tz 4 s, T1 10 s, T2 3 s) logged with 2 %
noise, first-order and lead-lag fits 4-9 % off the truth with clean flags were kept, and
called "ok", over the right ``lsq_zero_two_lags``, set aside for its wide zero interval
although its AIC on the same event was far lower. The "must stay ok" twins: a
first-order plant whose richer fits gain only on detail below the sample time, and the
same zero + two lags plant with windows long enough to determine it.
"""

from __future__ import annotations

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.fit import Fit, Flag, RefinementSummary
from pipeline.grading.recommendation import outfitted
from pipeline.models import ProcessModel
from pipeline.synth.montecarlo import PLANTS, Condition, mc_record, score

ONLY_MODELS = AnalysisOptions(tuning=None)


def _rows(plant: str, conditions, seeds) -> list[tuple[str, bool]]:
    out = []
    for cond in conditions:
        for seed in seeds:
            fit = analyse(mc_record(PLANTS[plant], cond, seed), ONLY_MODELS).recommended
            out.append((fit.verdict, score(fit.model, PLANTS[plant], cond).right))
    return out


def test_a_model_a_richer_fit_outfits_is_not_kept_as_ok_over_it():
    """15 records (2 % white noise with 3 T windows, AR(1) and 1/f with 6 T, 5 seeds each):
    right in at least 12 and wrong-and-ok in at most 3 (measured: 12 and 3; before: 6
    right, 9 wrong and ok)."""
    rows = _rows("zero_two_lags", (Condition("white", 0.02, 3.0), Condition("ar1", 0.02, 6.0),
                                   Condition("pink", 0.02, 6.0)), range(5))
    right = sum(r for _, r in rows)
    wrong_ok = sum(v == "ok" and not r for v, r in rows)
    assert right >= 12 and wrong_ok <= 3, rows


def test_richer_fits_that_gain_below_the_sample_time_keep_the_first_order_ok():
    """A first-order plant (delay 0.5 s, 0.2 s samples, 0.5 % white noise, 6 T windows): its
    ``lsq_zero_two_lags`` with a zero and a lag within one sample fits its event better
    beyond chance on seed 0, and does not displace the right first-order fit; the zero +
    two lags plant with 6 T windows and 2 % white noise stays ok and right too."""
    rows = _rows("fopdt_delay0.05", (Condition("white", 0.005, 6.0),), range(4))
    rows += _rows("zero_two_lags", (Condition("white", 0.02, 6.0),), range(3))
    assert rows == [("ok", True)] * 7, rows


def _fit(method: str, structure: str, params: dict, aic: float, flags=()) -> Fit:
    """A one-event fit with its AIC; a refinement (a summary with its parameter count:
    the model's and the offset) where the method is a least-squares one."""
    summary = RefinementSummary("rest", 0.0, 0.0, 1e-4, 500, 500.0, 1.0, len(params) + 1,
                                {}, 10, 1, "j") if method.startswith("lsq_") else None
    return Fit(method, 0, "ok", model=ProcessModel(structure, params), metrics={"aic": aic},
               flags=tuple(flags), refinement=summary)


def test_outfitted_is_a_bonferroni_likelihood_ratio_over_the_richer_refinements():
    """AIC = n_eff ln(SSE/n) + 2 k: one more parameter and an AIC 3 lower is a likelihood
    ratio of 5 > 3.84 (chi-square, 1 dof, 5 %) but < 5.02 (2.5 %, two richer fits tried);
    an AIC 8 lower (ratio 10) is beyond both. A richer fit with a part below the sample
    time, or a reading, does not count."""
    first = _fit("lsq_first_order", "first_order", {"K": 1.0, "T": 5.0}, -100.0)

    def lags(aic, flags=(), method="lsq_two_lags"):
        return _fit(method, "two_lags", {"K": 1.0, "T1": 5.0, "T2": 1.0}, aic, flags)

    assert outfitted(first, [first, lags(-103.0)])
    assert not outfitted(first, [first, lags(-103.0), lags(-101.0, method="lsq_n_lags")])
    assert outfitted(first, [first, lags(-108.0), lags(-101.0, method="lsq_n_lags")])
    fast = Flag("dynamics_below_sample_time", "T2 below the sample time")
    assert not outfitted(first, [first, lags(-120.0, [fast])])
    assert not outfitted(first, [first, lags(-120.0, method="harriott")])
    assert not outfitted(first, [first])
