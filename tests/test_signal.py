"""The noise estimate (pipeline.signal.noise_estimate) against known truth, and the
method guards it feeds, over many fixed seeds (statistical claims, STYLE.md 10)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from pipeline.methods import identify
from pipeline.signal import noise_estimate, noise_sigma, resolution
from tests.builders import fo, nl, noise, so, step, step_arrays

#: 1500-sample step responses (100 samples per time constant) from a nonzero operating point.
OP = dict(u0=1.0, u1=2.0, t0=10.0, y0=5.0, dt=0.05, after=65.0)


def errors(phi: float, n_seeds: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Relative sigma errors and rho1 over seeds, marginal noise 1 % of the step."""
    err, rho = [], []
    for seed in range(n_seeds):
        _, _, y = step_arrays(fo(5.0), **OP, noise_rel=0.01, phi=phi, seed=seed)
        est = noise_estimate(y)
        err.append(est.sigma / 0.02 - 1)
        rho.append(est.rho1)
    return np.array(err), np.array(rho)


def test_white_noise_within_15_percent() -> None:
    err, rho = errors(0.0)
    assert np.max(np.abs(err)) < 0.15, np.max(np.abs(err))
    assert abs(np.median(err)) < 0.03  # measured +1.9 % (max 7.1 %)
    assert np.all(np.abs(rho) < 0.15)


def test_ar1_noise_within_25_percent() -> None:
    """AR(1) phi = 0.8: the former median-fourth-difference estimate read 0.36 sigma."""
    err, rho = errors(0.8)
    assert np.max(np.abs(err)) < 0.25, np.max(np.abs(err))
    assert abs(np.median(err)) < 0.08  # measured +5.0 % (max 22.5 %)
    assert np.all(np.abs(rho - 0.8) < 0.1)
    est = noise_estimate(step_arrays(fo(5.0), **OP, noise_rel=0.01, phi=0.8)[2])
    assert est.correlation_samples == pytest.approx(9.0, rel=0.5)
    assert est.correlation_time == pytest.approx(-1 / math.log(0.8), rel=0.5)


@pytest.mark.parametrize("dt", [0.001, 0.01, 0.05, 0.2, 1.0])
def test_noise_free_response_reads_near_zero(dt: float) -> None:
    """A finely or coarsely sampled smooth response is not noise (relative to the step)."""
    for plant in (fo(5.0), nl(1.0, 4), so(0.3, 1.0)):
        _, _, y = step_arrays(plant, **dict(OP, dt=dt))
        assert noise_sigma(y) < 1e-6 * 2.0


def test_robust_to_steps_and_spikes() -> None:
    e = noise(4000, 0.01, 0.0, 1)
    y = e + np.where(np.arange(4000) > 2000, 5.0, 0.0)
    y[[300, 1200, 3100]] += 3.0
    assert noise_sigma(y) == pytest.approx(0.01, rel=0.1)


def test_quantised_sensor_is_not_noise_free() -> None:
    """A smooth response rounded to 0.244 (DaISy) reads at least q/sqrt(12)."""
    t, _, y = step_arrays(fo(5.0, K=60.0), **OP)
    yq = np.round(y / 0.244) * 0.244
    assert resolution(yq) == pytest.approx(0.244, rel=1e-6)
    assert noise_sigma(yq) >= 0.244 / math.sqrt(12) * (1 - 1e-9)
    assert resolution(y) == 0.0


def test_real_logs_resolution() -> None:
    from pipeline.io.datasets import fetch
    from tests.conftest import have_mirror

    if not have_mirror():
        pytest.skip("needs the dataset mirror")
    d = np.loadtxt(fetch("daisy-heating"))
    assert resolution(d[:, 2]) == pytest.approx(0.244, abs=1e-3)
    assert noise_sigma(d[:, 2]) > 0.244 / math.sqrt(12)
    tc = np.genfromtxt(fetch("tclab-kantor"), delimiter=",", skip_header=1)
    assert resolution(tc[:, 3]) == pytest.approx(0.32, abs=0.01)
    assert noise_sigma(tc[:, 3]) >= 0.32 / math.sqrt(12) * 0.97


# -- the guards, over 200 seeds -----------------------------------------------------------
def rate_ok(method: str, make, n: int = 200) -> float:
    return float(np.mean([identify(make(s), method).ok for s in range(n)]))


FO_AR1 = dict(OP, noise_rel=0.01, phi=0.8)


@pytest.mark.parametrize("method", ["second_order_overshoot", "second_order_pov"])
def test_oscillation_methods_refuse_coloured_noise(method: str) -> None:
    """First-order plant, AR(1) noise phi 0.8 of marginal std 1 % of the step: not ok in
    at least 95 % of 200 seeds (the former estimate accepted 99 % / 59 %); an underdamped
    plant (zeta 0.3) with 2 % white noise stays ok in at least 95 %."""
    assert rate_ok(method, lambda s: step(fo(5.0), seed=s, **FO_AR1)) <= 0.05
    so_op = dict(OP, noise_rel=0.02)
    assert rate_ok(method, lambda s: step(so(0.3, 1.0), seed=s, **so_op)) >= 0.95


@pytest.mark.parametrize("method", ["second_order_overshoot", "second_order_pov"])
def test_oscillation_guards_hold_with_an_underestimated_noise(method: str) -> None:
    """The guards alone (significance and period vs rise), with the noise read 0.36x too
    small as the former estimator did: still not ok in at least 90 % (measured 94 % / 99 %)."""
    def make(s):
        ev = step(fo(5.0), seed=s, **FO_AR1)
        return replace(ev, noise=0.36 * 0.02)

    assert rate_ok(method, make) <= 0.10


def test_smith_refuses_a_non_oscillating_high_order_lag() -> None:
    """1/(s+1)^4 with 1 % white noise: t20/t60 sits just below the undamped limit; not ok
    in at least 95 % of 200 seeds (was ok in 81 %, a near-undamped oscillator)."""
    op = dict(u0=1.0, u1=2.0, t0=5.0, y0=5.0, dt=0.05, after=30.0, noise_rel=0.01)
    assert rate_ok("smith", lambda s: step(nl(1.0, 4, K=1.0), seed=s, **op)) <= 0.05
