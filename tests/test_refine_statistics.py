"""The issue's statistical claims, measured over fixed seeds with known truth.

1. 50 seeds each, 1 % white noise (of K du), u 2 -> 5 at a nonzero time from y0 = 7, then a
   second step (5 -> 3) for validation; all methods, the recommended model against the
   best graphical model (lowest validation MSE among the graphical methods):
   FOPDT (K 2, T 10, delay 2), two lags + delay (K 1.5, T1 10, T2 3, delay 1), underdamped
   (K 0.8, zeta 0.3, wn 1 rad/s). The parameter error of a model is the largest relative
   error over all the true parameters (dead time and minor lag included), its parameters
   mapped onto the true structure where they are the same model (two real lags = an
   overdamped second order = an equal-lag pair; a first-order lag = two lags with T2 = 0);
   a model of another class has an infinite error. K and the dynamics the issue names (T;
   T1; zeta and wn) are bounded one by one (medians); ``-n0 -s`` prints every median.
   The sample time matters for the FOPDT ratio: the graphical dead time (a band exit read
   on smoothed data) is nearly as good as the least-squares one at T/20 (ratio 0.70 at
   dt 0.5 s), the least-squares one pulls ahead with more samples (0.45 at dt 0.1 s).
2. Coverage of the 95 % intervals of K and T of ``lsq_first_order`` over 200 seeds, white
   noise and AR(1) noise (phi 0.8, generated with scipy.signal.lfilter).
"""

import math

import numpy as np
import pytest
from scipy.signal import lfilter

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.grading import ranked
from pipeline.methods import REGISTRY, identify
from pipeline.models import ProcessModel
from pipeline.segmentation.detect import event_data
from pipeline.simulation.engine import simulate
from pipeline.synth import staircase, step_record

# name -> truth, time scale (s), sample time (s), the parameters the issue bounds
CASES = {
    "fopdt": (ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 2.0}), 10.0, 0.1,
              ("T",)),
    "two_lags": (ProcessModel("two_lags", {"K": 1.5, "T1": 10.0, "T2": 3.0, "delay": 1.0}),
                 13.0, 0.5, ("T1",)),
    "underdamped": (ProcessModel("second_order", {"K": 0.8, "zeta": 0.3, "wn": 1.0}), 3.3,
                    0.1, ("zeta", "wn")),
}
SEEDS = 50

#: model selection only (the tuning of the recommended model is tested in test_tuning*)
ONLY_MODELS = AnalysisOptions(tuning=None)


def equivalent(model: ProcessModel, structure: str) -> dict | None:
    """``model``'s parameters in ``structure`` when it is the same model, else None."""
    p, lags = model.params, model.lags()
    if model.structure == structure:
        return dict(p)
    if structure == "two_lags" and len(lags) == 2:
        return {"K": p["K"], "T1": max(lags), "T2": min(lags), "delay": model.delay}
    if structure == "second_order" and len(lags) == 2:
        a, b = lags
        return {"K": p["K"], "wn": 1 / math.sqrt(a * b),
                "zeta": (a + b) / (2 * math.sqrt(a * b)), "delay": model.delay}
    if structure == "first_order" and len(lags) == 1:
        return {"K": p["K"], "T": lags[0], "delay": model.delay}
    if structure == "two_lags" and len(lags) == 1:
        return {"K": p["K"], "T1": lags[0], "T2": 0.0, "delay": model.delay}
    return None


def errors(model: ProcessModel, truth: ProcessModel) -> dict[str, float]:
    q = equivalent(model, truth.structure)
    return {k: abs(q[k] / v - 1) if q else math.inf for k, v in truth.params.items() if v}


@pytest.fixture(scope="module")
def runs() -> dict[str, list[dict]]:
    out = {}
    for name, (truth, ts, dt, _) in CASES.items():
        sigma = 0.01 * truth.K * 3.0
        rows = []
        for seed in range(SEEDS):
            rec = step_record(truth, u0=2.0, changes=[(2 * ts, 5.0), (10 * ts, 3.0)],
                              t_end=18 * ts, dt=dt, y0=7.0, noise=sigma, seed=seed)
            res = analyse(rec, ONLY_MODELS)
            graphical = [f for f in ranked(res, 0) if REGISTRY[f.method].kind == "graphical"]
            rec_fit, best_graph = res.recommended, graphical[0]
            rows.append({"rec": errors(rec_fit.model, truth),
                         "graph": errors(best_graph.model, truth),
                         "rec_mse": rec_fit.metrics["mse_validation"] / sigma**2,
                         "graph_mse": best_graph.metrics["mse_validation"] / sigma**2,
                         "method": rec_fit.method})
        out[name] = rows
    return out


@pytest.mark.parametrize("name", list(CASES))
def test_recommended_model_beats_the_best_graphical_one(runs, name):
    truth, _, _, named = CASES[name]
    rows = runs[name]
    rec_err = np.median([max(r["rec"].values()) for r in rows])
    graph_err = np.median([max(r["graph"].values()) for r in rows])
    med = {k: float(np.median([r["rec"][k] for r in rows])) for k in truth.params
           if truth.params[k]}
    med_graph = {k: float(np.median([r["graph"][k] for r in rows])) for k in med}
    rec_mse = float(np.median([r["rec_mse"] for r in rows]))
    print(f"\n{name}: parameter error recommended {rec_err:.4f}, best graphical "
          f"{graph_err:.4f}; per parameter recommended {med}, best graphical {med_graph}; "
          f"validation MSE/sigma^2 recommended {rec_mse:.3f}, best graphical "
          f"{np.median([r['graph_mse'] for r in rows]):.3f}; recommended methods "
          f"{sorted({r['method'] for r in rows})}")
    assert rec_err <= 0.5 * graph_err
    assert med["K"] <= 0.02
    assert all(med[k] <= 0.05 for k in named)
    assert rec_mse <= 1.1
    same_class = np.mean([all(math.isfinite(v) for v in r["rec"].values()) for r in rows])
    assert same_class >= 0.9


def _coverage(phi: float, n_seeds: int = 200) -> tuple[dict[str, float], float]:
    truth = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 2.0})
    t = np.arange(0, 100.25, 0.5)
    u = staircase(t, 2.0, [(20.0, 5.0)])
    y_true = simulate(truth, t, u, 2.0, 7.0)
    sigma = 0.06
    w = np.random.default_rng(1234).normal(0.0, sigma * math.sqrt(1 - phi**2),
                                           (n_seeds, t.size + 200))
    noise = lfilter([1.0], [1.0, -phi], w, axis=1)[:, 200:]  # stationary AR(1), std sigma
    hits = {"K": 0, "T": 0}
    factors = []
    for e in noise:
        fit = identify(event_data(t, u, y_true + e), "lsq_first_order")
        for k in hits:
            lo, hi = fit.ci95[k]
            hits[k] += lo <= truth.params[k] <= hi
        factors.append(fit.refinement.variance_factor)
    return {k: v / n_seeds for k, v in hits.items()}, float(np.median(factors))


def test_interval_coverage_white_noise():
    cov, f = _coverage(0.0)
    print(f"\nwhite noise: coverage {cov}, median variance factor {f:.2f}")
    assert all(0.90 <= c <= 0.99 for c in cov.values())


def test_interval_coverage_ar1_noise():
    cov, f = _coverage(0.8)
    print(f"\nAR(1) phi 0.8: coverage {cov}, median variance factor {f:.2f} (true 9)")
    assert all(c >= 0.85 for c in cov.values())


@pytest.mark.parametrize("a", [0.0, 0.5, 0.9, 0.99])
def test_variance_factor_by_direct_products_is_the_fft_one(a, monkeypatch):
    """Long residuals take their leading autocorrelations as direct products (the FFT
    only when the initial positive sequence has not ended by then): the same factor,
    to rounding, white or coloured, and the known AR(1) value (1 + a) / (1 - a)."""
    from pipeline import uncertainty
    e = lfilter([1.0], [1.0, -a], np.random.default_rng(3).normal(size=50_000))
    direct = uncertainty.variance_factor(e)
    monkeypatch.setattr(uncertainty, "DIRECT_FROM", 10**12)
    assert uncertainty.variance_factor(e) == pytest.approx(direct, rel=1e-12)
    assert direct == pytest.approx((1 + a) / (1 - a), rel=0.12 if a < 0.95 else 0.3)
