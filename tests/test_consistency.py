"""Per-event consistency statistics on known estimates (the end-to-end checks through the
analysis are in tests/test_consistency_e2e.py)."""

from __future__ import annotations

import numpy as np

from pipeline.grading.consistency import EventEstimate, gain_flags, static_map, static_map_note


def est(i, u0, u1, K, se, y0=0.0, T=10.0):
    return EventEstimate(i, 100.0 * i, u0, u1, y0, y0 + K * (u1 - u0), K,
                         (K - 1.96 * se, K + 1.96 * se), T, (T - 1, T + 1), K_se=se)


def test_equal_gains_within_noise_raise_nothing():
    rng = np.random.default_rng(0)
    alarms = 0
    for _ in range(1000):
        ks = 2.0 + rng.normal(0, 0.02, 4)
        e = [est(i, i + 1, i + 2, k, 0.02) for i, k in enumerate(ks)]
        alarms += bool(gain_flags(e))
    assert alarms <= 3  # alpha = 1e-3 per test, two tests per log


def test_gains_that_fall_with_the_level_are_inconsistent():
    e = [est(0, 6, 9, 20.8, 0.2), est(1, 9, 4, 18.0, 0.2), est(2, 4, 8, 17.0, 0.2),
         est(3, 8, 3, 14.7, 0.2)]
    (f,) = [x for x in gain_flags(e, "degC/V") if x.code == "gain_inconsistent"]
    assert "20.8, 18, 17, 14.7 degC/V" in f.message and f.values["spread"] > 0.25


def test_significant_but_tiny_differences_are_not_alarms():
    e = [est(i, i, i + 1, 2.0 + 0.01 * i, 1e-5) for i in range(4)]  # 1.5 % spread
    assert not gain_flags(e)


def test_direction_asymmetry():
    e = [est(0, 1, 2, 2.0, 0.02), est(1, 2, 1, 1.5, 0.02), est(2, 1, 2, 2.02, 0.02),
         est(3, 2, 1, 1.52, 0.02)]
    assert {f.code for f in gain_flags(e)} == {"gain_inconsistent", "direction_asymmetry"}


def test_a_level_dependent_gain_is_not_asymmetric():
    """A square law: each step's gain is u_before + u_after, whatever its direction (up
    steps happen to sit higher here): inconsistent, not asymmetric."""
    steps = [(2, 4), (4, 6), (6, 3), (3, 5), (5, 2), (2, 7)]
    e = [est(i, a, b, a + b, 0.01) for i, (a, b) in enumerate(steps)]
    assert {f.code for f in gain_flags(e)} == {"gain_inconsistent"}


def test_static_map_of_a_square_law_is_not_a_line():
    levels = [6, 9, 4, 8, 3, 7, 6]
    e = []
    for i in range(len(levels) - 1):
        u0, u1 = levels[i], levels[i + 1]
        y0, y1 = 100 + 1.0 * u0**2, 100 + 1.0 * u1**2
        e.append(EventEstimate(i, 200.0 * i, u0, u1, y0, y1, (y1 - y0) / (u1 - u0),
                               (0, 0), 60.0, (50, 70), K_se=0.01))
    m = static_map(e)
    assert m.nonlinear and m.rms_quadratic < 1e-9 < m.rms_line
    assert m.quadratic[2] == np.float64(m.quadratic[2]) and abs(m.quadratic[2] - 1.0) < 1e-9
    assert "u^2" in static_map_note(m, {"output": "degC"})
    lin = [EventEstimate(x.index, x.t0, x.u0, x.u1, 3 * x.u0, 3 * x.u1, 3.0, (2.9, 3.1), 60,
                         (50, 70), K_se=0.05) for x in e]
    assert not static_map(lin).nonlinear and static_map_note(static_map(lin), {}) is None
