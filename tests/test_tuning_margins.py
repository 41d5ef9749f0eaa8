"""Margins with an exact dead time (pipeline.tuning.margins) against known truth.

Truth comes from closed forms, from Skogestad (2003) for SIMC PI loops, from an independent
brute-force sweep of two million log-spaced frequencies done here with plain numpy, and from
the closed-loop poles of a Padé(20) approximation (python-control) for proper plants.
"""

import math

import control
import numpy as np
import pytest
from scipy.optimize import brentq

from pipeline.tuning.margins import Margins, _contour, _s, _winding, loop_margins, sensitivity_peaks


def fopdt_pi(K: float, T: float, theta: float, Kc: float, Ti: float | None = None):
    """L = Kc (1 + 1/(Ti s)) K e^(-theta s)/(T s + 1); P only when Ti is None."""
    def loop(s):
        c = Kc if Ti is None else Kc * (1 + 1 / (Ti * s))
        return c * K * np.exp(-theta * s) / (T * s + 1)
    return loop


def simc(K: float, T: float, theta: float) -> tuple[float, float]:
    """SIMC PI with tau_c = theta (Skogestad 2003)."""
    return T / (K * 2 * theta), min(T, 8 * theta)


def brute(loop, w_lo: float, w_hi: float, n: int = 2_000_000) -> tuple[float, float, float]:
    """(Ms, GM, PM [deg]) from a dense log sweep with linear interpolation at the crossings."""
    w = np.logspace(math.log10(w_lo), math.log10(w_hi), n)
    L = loop(1j * w)
    ms = float(np.max(1 / np.abs(1 + L)))
    mag = np.abs(L)
    k = np.nonzero((np.sign(L.imag[:-1]) != np.sign(L.imag[1:]))
                   & (L.real[:-1] < 0) & (L.real[1:] < 0))[0]
    frac = L.imag[k] / (L.imag[k] - L.imag[k + 1])
    gm = float(1 / np.max(mag[k] + frac * (mag[k + 1] - mag[k]))) if k.size else math.inf
    k = np.nonzero(np.sign(mag[:-1] - 1) != np.sign(mag[1:] - 1))[0]
    frac = (mag[k] - 1) / (mag[k] - mag[k + 1])
    lc = L[k] + frac * (L[k + 1] - L[k])
    pm = 180 + np.degrees(np.angle(lc))
    pm = 180 - np.mod(180 - pm, 360)
    return ms, gm, float(np.min(pm)) if k.size else math.inf


def close(a: float, b: float, rel: float) -> bool:
    return abs(a - b) <= rel * abs(b)


RATIOS = [0.1, 0.5, 1, 2, 4, 8, 20]


@pytest.mark.parametrize("ratio", RATIOS)
def test_simc_fopdt_against_brute_force(ratio: float) -> None:
    K, theta = 1.7, 1.0
    T = ratio * theta
    Kc, Ti = simc(K, T, theta)
    loop = fopdt_pi(K, T, theta, Kc, Ti)
    m = loop_margins(loop, delay=theta, time_scale=T, origin_poles=1)
    ms, gm, pm = brute(loop, 1e-4 / max(T, theta), 1e3 / theta)
    assert m.stable
    assert close(m.ms, ms, 0.01) and close(m.gain_margin, gm, 0.01)
    assert close(m.phase_margin, pm, 0.01)
    if ratio >= 1:  # Skogestad (2003): Ms 1.59-1.70, GM 2.96-3.14 for tau_c = theta
        assert 1.55 < m.ms < 1.75 and 2.9 < m.gain_margin < 3.3
    if ratio <= 8:  # Ti = T: L = e^(-theta s)/(2 theta s), closed forms
        assert m.gain_margin == pytest.approx(math.pi, rel=1e-6)
        assert m.w180 == pytest.approx(math.pi / 2, rel=1e-6)
        assert m.phase_margin == pytest.approx(90 - math.degrees(0.5), rel=1e-6)
        assert m.wc == pytest.approx(0.5, rel=1e-6)
        assert m.delay_margin == pytest.approx(math.pi - 1, rel=1e-6)
        assert m.ms == pytest.approx(1.59, abs=0.005)
    # Skogestad & Postlethwaite (2.42): GM >= Ms/(Ms-1), PM >= 2 arcsin(1/(2 Ms))
    assert m.gain_margin >= m.ms / (m.ms - 1)
    assert m.phase_margin >= math.degrees(2 * math.asin(1 / (2 * m.ms)))


def test_integrator_with_delay_simc() -> None:
    k, theta = 0.3, 2.0
    Kc, Ti = 1 / (k * 2 * theta), 4 * 2 * theta
    m = loop_margins(lambda s: Kc * (1 + 1 / (Ti * s)) * k * np.exp(-theta * s) / s,
                     delay=theta, time_scale=theta, origin_poles=2)
    assert m.stable
    assert m.ms == pytest.approx(1.70, rel=0.02)
    assert m.gain_margin == pytest.approx(2.96, rel=0.02)
    assert m.phase_margin == pytest.approx(46.9, rel=0.02)
    assert 1 < m.mt < m.ms


def test_proportional_fopdt_critical_gain() -> None:
    w180 = brentq(lambda w: math.atan(w) + w - math.pi, 1, 3)
    ku = math.hypot(1, w180)
    assert ku == pytest.approx(2.2611, rel=0.005) and w180 == pytest.approx(2.0288, rel=1e-4)
    m1 = loop_margins(fopdt_pi(1, 1, 1, 1.0), delay=1, time_scale=1)
    assert m1.stable
    assert m1.gain_margin == pytest.approx(ku, rel=1e-6)
    assert m1.w180 == pytest.approx(w180, rel=1e-6)
    assert loop_margins(fopdt_pi(1, 1, 1, 2.0), delay=1, time_scale=1).stable
    m3 = loop_margins(fopdt_pi(1, 1, 1, 3.0), delay=1, time_scale=1)
    assert not m3.stable and m3.delay_margin == 0 and m3.gain_margin < 1
    assert m3.phase_margin < 0


def test_open_loop_unstable_plant() -> None:
    """P = 1/(s-1): the Nyquist plot of 2/(s-1) encircles -1 once counter-clockwise (N = -1),
    Z = N + P = 0; with gain 0.5 there is no encirclement and Z = 1."""
    m2 = loop_margins(lambda s: 2 / (s - 1), delay=0, time_scale=1, rhp_poles=1)
    assert m2.stable
    assert m2.ms == pytest.approx(1.0, rel=1e-6)  # S = (s-1)/(s+1) is all-pass
    assert m2.mt == pytest.approx(2.0, rel=1e-6)  # T = 2/(s+1)
    assert m2.phase_margin == pytest.approx(60.0, rel=1e-6)
    assert m2.wc == pytest.approx(math.sqrt(3), rel=1e-6)
    assert not loop_margins(lambda s: 0.5 / (s - 1), delay=0, time_scale=1, rhp_poles=1).stable
    ms, stable = sensitivity_peaks(lambda s: np.array([0.5, 2.0])[:, None] / (s - 1), delay=0,
                                   time_scale=1, rhp_poles=1)
    assert stable.tolist() == [False, True] and ms[1] == pytest.approx(1.0, rel=1e-6)
    # forgetting the open-loop pole: Z = N + P = -1 + 0 != 0
    assert not loop_margins(lambda s: 2 / (s - 1), delay=0, time_scale=1).stable
    # with a dead time and an integrator as well: e^(-0.1 s) (s + 1)/(s (s - 1)) x 3
    loop = lambda s: 3 * (s + 1) * np.exp(-0.1 * s) / (s * (s - 1))  # noqa: E731
    assert loop_margins(loop, delay=0.1, time_scale=1, origin_poles=1, rhp_poles=1).stable


@pytest.mark.parametrize("gain", [0.5, 2.0, 7.9, 8.1, 30.0, 300.0])
@pytest.mark.parametrize("origin", [0, 1])
def test_winding_counts_closed_loop_rhp_poles(gain: float, origin: int) -> None:
    """N = Z (P = 0) against the roots of the characteristic polynomial: K/(s+1)^3 (two
    right-half-plane poles for K > 8) and K (s + 0.5)/(s (s+1)^3) (round the origin)."""
    num = np.array([gain]) if origin == 0 else gain * np.array([1.0, 0.5])
    den = np.polymul([1.0, 0.0] if origin else [1.0], np.poly([-1.0, -1.0, -1.0]))
    z = int(np.sum(np.roots(np.polyadd(den, num)).real > 0))
    t, eps = _contour(np.logspace(-4, 4, 500), origin)

    def one_plus_l(tt):
        s = _s(tt, eps)
        return 1 + np.polyval(num, s) / np.polyval(den, s)

    n, _, _ = _winding(one_plus_l, t, one_plus_l(t))
    assert n == z
    m = loop_margins(lambda s: np.polyval(num, s) / np.polyval(den, s), delay=0, time_scale=3,
                     origin_poles=origin)
    assert m.stable is (z == 0)


def test_delay_margin() -> None:
    m1 = loop_margins(fopdt_pi(1, 1, 1, 1.0), delay=1, time_scale=1)
    assert m1.phase_margin == math.inf and m1.delay_margin == math.inf and math.isnan(m1.wc)
    m2 = loop_margins(fopdt_pi(1, 1, 1, 2.0), delay=1, time_scale=1)
    wc = math.sqrt(3)
    pm = 180 - math.degrees(math.atan(wc)) - math.degrees(wc)
    assert m2.wc == pytest.approx(wc, rel=1e-6)
    assert m2.phase_margin == pytest.approx(pm, rel=0.005)
    dm = math.radians(pm) / wc
    assert m2.delay_margin == pytest.approx(dm, rel=0.005)
    for factor, stable in ((0.99, True), (1.01, False)):
        theta = 1 + factor * dm
        m = loop_margins(fopdt_pi(1, 1, theta, 2.0), delay=theta, time_scale=1)
        assert m.stable is stable


def _random_batch(m: int, seed: int = 7):
    rng = np.random.default_rng(seed)
    K = rng.uniform(0.5, 2, m)
    T = rng.uniform(0.2, 10, m)
    th = rng.uniform(0.2, 2, m)
    Kc = T / (K * 2 * th) * rng.uniform(0.2, 4.5, m)
    Ti = np.minimum(T, 8 * th) * rng.uniform(0.5, 2, m)

    def loops(s):
        s = s[None, :]
        return ((Kc * K)[:, None] * (1 + 1 / (Ti[:, None] * s)) * np.exp(-th[:, None] * s)
                / (T[:, None] * s + 1))
    return K, T, th, Kc, Ti, loops


def test_sensitivity_peaks_agrees_with_loop_margins() -> None:
    K, T, th, Kc, Ti, loops = _random_batch(200)
    ms, stable = sensitivity_peaks(loops, delay=th.max(), time_scale=T.max(), origin_poles=1)
    assert ms.shape == stable.shape == (200,)
    ref = [loop_margins(fopdt_pi(K[i], T[i], th[i], Kc[i], Ti[i]), delay=th[i],
                        time_scale=T[i], origin_poles=1) for i in range(200)]
    assert np.array_equal(stable, [r.stable for r in ref])
    assert 20 < np.sum(~stable) < 180
    r_ms = np.array([r.ms for r in ref])
    # past Ms = 50 (a pass within 2 % of -1) the common grid may resolve the peak less well
    sharp = r_ms > 50
    assert np.all(np.abs(ms[~sharp] / r_ms[~sharp] - 1) < 0.01)
    assert np.all(np.abs(ms[sharp] / r_ms[sharp] - 1) < 0.05)


def test_time_scale_invariance() -> None:
    theta, T = 1.0, 20.0
    Kc, Ti = simc(1.0, T, theta)
    ref = loop_margins(fopdt_pi(1.0, T, theta, Kc, Ti), delay=theta, time_scale=T,
                       origin_poles=1)
    for a in (1e-3, 1e5):
        m = loop_margins(fopdt_pi(1.0, a * T, a * theta, Kc, a * Ti), delay=a * theta,
                         time_scale=a * T, origin_poles=1)
        assert m.stable
        for name in ("ms", "mt", "gain_margin", "phase_margin"):
            assert getattr(m, name) == pytest.approx(getattr(ref, name), rel=1e-6)
        for name in ("w_ms", "w180", "wc"):
            assert getattr(m, name) == pytest.approx(getattr(ref, name) / a, rel=1e-6)
        assert m.delay_margin == pytest.approx(ref.delay_margin * a, rel=1e-6)
        ms, stable = sensitivity_peaks(lambda s, a=a: fopdt_pi(1.0, a * T, a * theta, Kc,
                                                               a * Ti)(s)[None, :],
                                       delay=a * theta, time_scale=a * T, origin_poles=1)
        assert stable[0] and ms[0] == pytest.approx(ref.ms, rel=0.005)


@pytest.mark.parametrize(("T", "theta", "Kc", "Ti"),
                         [(1.0, 100.0, 0.004, 50.0),   # dead-time dominant, delay/T = 100
                          (1.0, 1e-3, 300.0, 0.01)])   # lag dominant, delay/T = 1e-3
def test_extreme_delay_ratios(T: float, theta: float, Kc: float, Ti: float) -> None:
    loop = fopdt_pi(1.0, T, theta, Kc, Ti)
    m = loop_margins(loop, delay=theta, time_scale=T, origin_poles=1)
    ms, gm, pm = brute(loop, 1e-4 / max(T, theta), 1e3 / theta)
    assert m.stable
    assert close(m.ms, ms, 0.01) and close(m.gain_margin, gm, 0.01)
    assert close(m.phase_margin, pm, 0.01)
    b_ms, b_stable = sensitivity_peaks(lambda s: loop(s)[None, :], delay=theta, time_scale=T,
                                       origin_poles=1)
    assert b_stable[0] and close(b_ms[0], m.ms, 0.01)


def _pade_stable(K, T, Tz, theta, Kc, Ti) -> bool:
    P = control.tf([K * Tz, K], [T, 1])
    C = control.tf([Kc * Ti, Kc], [Ti, 0])
    D = control.tf(*control.pade(theta, 20))
    return bool(np.max(control.poles(control.feedback(C * P * D, 1)).real) < 0)


@pytest.mark.parametrize(("Tz", "Kc", "Ti", "high"),
                         [(3.0, 0.5, 1.0, 1.5),    # |L(j inf)| = 1.5: unstable
                          (2.0, 0.55, 3.0, 1.1),   # 1.1: unstable although slow and gentle
                          (0.5, 1.0, 2.0, 0.5),    # 0.5: stable
                          (0.1, 5.0, 2.0, 0.5),    # 0.5 but too much gain: unstable
                          (0.8, 1.0, 1.5, 0.8)])   # 0.8: stable, Ms >= 1/(1 - 0.8)
def test_proper_plant_lead_lag(Tz: float, Kc: float, Ti: float, high: float) -> None:
    K, T, theta = 1.0, 1.0, 1.0
    assert K * Kc * Tz / T == pytest.approx(high)

    def loop(s):
        return Kc * (1 + 1 / (Ti * s)) * K * (Tz * s + 1) / (T * s + 1) * np.exp(-theta * s)

    m = loop_margins(loop, delay=theta, time_scale=T, origin_poles=1)
    ms, stable = sensitivity_peaks(lambda s: loop(s)[None, :], delay=theta, time_scale=T,
                                   origin_poles=1)
    assert stable[0] == m.stable
    if high >= 1:
        assert not m.stable and m.delay_margin == 0
        return
    assert m.stable == _pade_stable(K, T, Tz, theta, Kc, Ti)
    b_ms, b_gm, _ = brute(loop, 1e-4, 1e3)
    assert close(m.ms, b_ms, 0.01) and close(ms[0], b_ms, 0.01)
    assert m.ms >= 0.99 / (1 - high)
    assert close(m.gain_margin, b_gm, 0.01)


def test_margins_is_frozen() -> None:
    m = loop_margins(fopdt_pi(1, 1, 1, 1.0), delay=1, time_scale=1)
    assert isinstance(m, Margins)
    with pytest.raises(AttributeError):
        m.ms = 2.0  # type: ignore[misc]


def test_an_integral_controller_of_a_pure_gain_is_stable_not_overflowed() -> None:
    """A lead-lag whose zero cancels its lag (Tz 1.23 s, T 1.236 s) is a pure gain to
    SIMC's rule T2: the PI limit Kc, Ti -> 0 (Kc 5.02e-309, Ti 1e-309 s), an integral
    controller with Ki = Kc / Ti = 5.02 /s. Its response is Kc + Ki / s to the bit of
    the quotient (1/(Ti s) overflowed and the loop read as unstable on the model); the
    loop ``Ki K / s`` with K 2 crosses over at 10 rad/s with a phase margin of 90 deg."""
    import warnings

    from pipeline.models import ProcessModel
    from pipeline.tuning import Controller
    from pipeline.tuning.tuner import tune

    c = Controller.ideal(5.022e-309, 1e-309)
    s = 1j * np.array([0.1, 1.0, 10.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = c.response(s)
        tuned = tune(ProcessModel("lead_lag", {"K": 2.0, "Tz": 1.23, "T": 1.236,
                                               "delay": 0.0}))
    assert np.allclose(r, 5.022 / s, rtol=1e-12)
    assert tuned.margins.stable and tuned.margins.phase_margin == pytest.approx(90, abs=1)
