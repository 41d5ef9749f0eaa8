"""Refinement of the new structures with known truth, over 50 noise seeds: the integrator
with a lag and the pure integrator (graphical reading and least squares), a pulse on the
integrator, the inverse response, and lead-lag / zero-over-two-lags plants that used to
land in a pure-gain local minimum.

Noise definitions (the same for the graphical and the refined model of a case):

* a step on an integrator: 1 % of the ramp's rise over its lag, ``K du (T + L)`` (sigma
  0.05 for K 0.5 /s, T 4 s, L 1 s, du 2). At 1 % of the whole ramp's range the Cramer-Rao
  bound on T is about 4.7 %, so 2 % is out of reach there;
* a pulse on an integrator: 1 % of the level shift ``K A`` (sigma 0.02 for A = 4);
* a step on a self-regulating plant: 1 % of the change ``K du``.

Statistical claims are over the seeds 0-49 (fixed). Where a tolerance is near the
information limit, the test states the bound and asks for a rate, not every seed: the
refined T of the integrator has a Cramer-Rao standard deviation of 0.70 % on a 50 s window
(0.97 % on 30 s, where 2 % held in 47 of 50 seeds, as the bound predicts); the inverse
response's T2 one of 2.2 %, so 5 % is 2.2 standard deviations (~97 % of seeds).
"""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.methods import identify
from pipeline.models import ProcessModel
from pipeline.simulation import forced_response
from pipeline.simulation.engine import simulate
from tests.test_integrating import INT, INT_LAG, RAMP_NOISE, inverse_event, pulse_event, step_event

SEEDS = range(50)
DT = 0.1


def _errors(fits, truth: ProcessModel, names) -> np.ndarray:
    """Relative errors (rows: seeds) of ``names``; NaN where a fit failed or has another
    structure."""
    rows = []
    for f in fits:
        ok = f.ok and f.model.structure == truth.structure
        rows.append([f.model.params[n] / truth.params[n] - 1 if ok else np.nan for n in names])
    return np.abs(np.array(rows))


def _rate(err: np.ndarray, tol: float) -> np.ndarray:
    """Share of seeds within ``tol`` (a failed fit counts as outside)."""
    return np.mean(np.nan_to_num(err, nan=np.inf) <= tol, axis=0)


@pytest.fixture(scope="module")
def integrator_lag_fits():
    """A step 1 -> 3 at 10 s from the output level 3, 50 s after it (10 (T + L))."""
    events = [step_event(INT_LAG, s, noise=RAMP_NOISE, t_end=60.0) for s in SEEDS]
    return ([identify(ev, "integrator_asymptote") for ev in events],
            [identify(ev, "lsq_integrator_lag") for ev in events])


def test_integrator_with_lag_graphical_within_5_percent(integrator_lag_fits):
    """Asymptote and bend: K and T within 5 % in every seed (medians 0.02 % and 0.6 %),
    the dead time within one sample."""
    graphical, _ = integrator_lag_fits
    err = _errors(graphical, INT_LAG, ("K", "T"))
    assert np.all(_rate(err, 0.05) == 1.0)
    assert np.median(err[:, 0]) < 0.002 and np.median(err[:, 1]) < 0.01
    assert max(abs(f.model.delay - 1.0) for f in graphical) <= DT


def test_integrator_with_lag_refined_within_2_percent(integrator_lag_fits):
    """Least squares at rest (the balance point is the input before the step): K within
    2 % in every seed, T in at least 96 % (all 50 here; medians 0.02 % and 0.5 %); each
    parameter's 95 % interval covers the truth in at least 90 % of seeds (K 94 %, T 92 %,
    delay 94 % here)."""
    _, refined = integrator_lag_fits
    err = _errors(refined, INT_LAG, ("K", "T"))
    assert _rate(err, 0.02)[0] == 1.0 and _rate(err, 0.02)[1] >= 0.96
    assert np.median(err[:, 0]) < 0.002 and np.median(err[:, 1]) < 0.01
    assert all(f.refinement.u0 == 1.0 and f.refinement.state_text == "rest"
               for f in refined)
    for n in ("K", "T", "delay"):
        assert np.mean([f.ci95[n][0] <= INT_LAG.params[n] <= f.ci95[n][1]
                        for f in refined]) >= 0.9, n


def test_pulse_on_the_integrator_with_lag():
    """A pulse of area 4 (height 4 for 1 s): the level shift over the area gives K within
    3 % in every seed (median 0.2 %); the refinement, driven by the measured pulse, K
    within 1 % and T within 3 % in every seed."""
    events = [pulse_event(INT_LAG, s, noise=0.02) for s in SEEDS]
    err = _errors([identify(ev, "integrator_pulse") for ev in events], INT_LAG, ("K",))
    assert _rate(err, 0.03)[0] == 1.0 and np.median(err) < 0.01
    refined = [identify(ev, "lsq_integrator_lag") for ev in events]
    err = _errors(refined, INT_LAG, ("K", "T"))
    assert _rate(err, 0.01)[0] == 1.0 and _rate(err, 0.03)[1] == 1.0
    assert all(f.refinement.state_text == "rest" for f in refined)


@pytest.mark.parametrize("method", ["integrator_asymptote", "lsq_integrator"])
def test_pure_integrator_with_delay(method):
    """``0.5 e^{-s}/s``: K within 2 % (medians 0.01 %) and the dead time within one sample
    (0.1 s) in every seed, by the asymptote and by least squares."""
    fits = [identify(step_event(INT, s, noise=RAMP_NOISE, t_end=60.0), method) for s in SEEDS]
    assert all(f.ok and f.model.structure == "integrator" for f in fits)
    err = _errors(fits, INT, ("K",))
    assert _rate(err, 0.02)[0] == 1.0 and np.median(err) < 0.001
    assert max(abs(f.model.delay - 1.0) for f in fits) <= DT


def test_inverse_response_refined_within_5_percent():
    """``2 (-3 s + 1) e^{-s}/((8 s + 1)(2 s + 1))``, 1 % noise: K, Tz, T1 and T2 within 5 %
    in at least 96 % of seeds (K, Tz, T1 in all; T2 in 49 of 50: its bound is 2.2 %),
    medians below 1 %; the dead time within one sample."""
    truth = ProcessModel("zero_two_lags", {"K": 2.0, "Tz": -3.0, "T1": 8.0, "T2": 2.0,
                                           "delay": 1.0})
    fits = [identify(inverse_event(s), "lsq_zero_two_lags") for s in SEEDS]
    err = _errors(fits, truth, ("K", "Tz", "T1", "T2"))
    assert np.all(_rate(err, 0.05) >= 0.96) and np.all(np.median(err, axis=0) < 0.01)
    assert max(abs(f.model.delay - 1.0) for f in fits) <= DT


ZEROS = [
    ProcessModel("lead_lag", {"K": 2.0, "Tz": 6.0, "T": 3.0, "delay": 1.0}),  # overshoot
    ProcessModel("lead_lag", {"K": 2.0, "Tz": -2.0, "T": 5.0, "delay": 1.0}),  # jumps back
    ProcessModel("lead_lag", {"K": 1.0, "Tz": 1.5, "T": 6.0, "delay": 0.5}),
    ProcessModel("lead_lag", {"K": -1.0, "Tz": -4.0, "T": 2.0, "delay": 0.0}),
    ProcessModel("zero_two_lags", {"K": 1.5, "Tz": 12.0, "T1": 6.0, "T2": 2.0, "delay": 1.0}),
    ProcessModel("zero_two_lags", {"K": 1.5, "Tz": 5.0, "T1": 6.0, "T2": 1.0, "delay": 1.0}),
]


@pytest.mark.parametrize("truth", ZEROS, ids=lambda m: m.text())
def test_zeros_of_either_sign_are_found(truth):
    """Plants with a zero, stepped 1 -> 3 with 1 % noise (10 seeds): every parameter within
    10 % (the zero's Tz solved with the gain inside the search; the dead time of a
    response that jumps started where it leaves its noise band). From the first-order
    readings alone these fell into a pure-gain local minimum (K Tz/T ~ K)."""
    from pipeline.segmentation.detect import event_data
    from pipeline.synth import response, staircase

    t = np.arange(901) * DT
    u = staircase(t, 1.0, [(10.0, 3.0)])
    for seed in range(10):
        ev = event_data(t, u, response(truth, t, u, 1.0, 3.0, 0.02 * abs(truth.K), seed))
        fit = identify(ev, f"lsq_{truth.structure}")
        assert fit.ok, fit.reason
        for n, v in truth.params.items():
            assert fit.model.params[n] == pytest.approx(v, rel=0.1, abs=0.1), (seed, n)


@pytest.mark.parametrize("delay", [0.0, 2 * DT, 0.37])
def test_regressors_see_a_lead_lags_jump_where_the_simulation_does(delay):
    """The refinement's forced response of a lead-lag equals the simulator's, the jump at a
    dead time of 0 or a whole number of samples included (it came one sample late)."""
    m = ProcessModel("lead_lag", {"K": 1.0, "Tz": 6.0, "T": 3.0, "delay": delay})
    t = np.arange(200) * DT
    u = np.where(np.arange(200) >= 20, 3.0, 1.0) + 0.1 * np.sin(0.3 * t) * (t > 8)
    x = forced_response("lead_lag", dict(m.params), t, u - 1.0)
    assert np.max(np.abs(x - simulate(m, t, u, 1.0, 0.0))) < 1e-12
