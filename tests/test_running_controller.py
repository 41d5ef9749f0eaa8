"""The running controller's settings read off its log (issue 32 item 1), against known
truth: the closed-loop bench's P, PI and PID loops (:mod:`pipeline.synth.closed_loop`)
around a first-order plant, two lags, an integrator with a lag and unstable plants, SIMC
settings and detuned 2x, setpoint and load steps, white and AR(1) measurement noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.synth.closed_loop import LOOP_TUNINGS, loop_record, pi_loop_record
from pipeline.tuning.running import identify_controller

SETPOINTS = ((20.0, 55.0), (120.0, 47.0), (220.0, 52.0))
LOADS = ((170.0, 0.5),)


def _setpoint(t: np.ndarray, r0: float = 50.0, setpoints=SETPOINTS) -> np.ndarray:
    r = np.full(t.size, r0)
    for t_c, level in sorted(setpoints):
        r[t >= t_c - 1e-9] = level
    return r


CASES = [(p, c) for p, tunings in LOOP_TUNINGS.items() for c in tunings]


@pytest.mark.parametrize("detune", [1.0, 2.0])
@pytest.mark.parametrize(("plant", "kind"), CASES)
def test_settings_within_5_percent(plant, kind, detune):
    kc, ti, td = LOOP_TUNINGS[plant][kind]
    for seed, (noise, phi) in enumerate(((0.05, 0.0), (0.05, 0.9))):
        rec = loop_record(plant, kind, detune=detune, noise=noise, noise_phi=phi,
                          loads=LOADS, seed=seed)
        got = identify_controller(rec.t, _setpoint(rec.t), rec.y, rec.u)
        c = got.controller
        assert c.kind == kind
        assert c.Kc == pytest.approx(kc / detune, rel=0.05)
        if math.isfinite(ti):
            assert c.Ti == pytest.approx(ti, rel=0.05)
        if td:
            assert c.Td == pytest.approx(td, rel=0.05)
        assert got.residual_share < 1e-6  # the bench's controller is the one assumed
        assert got.converged


def test_velocity_form_pi_is_read_the_same():
    """A velocity-form PI (the first closed-loop generator) is the positional one summed:
    the same settings."""
    rec = pi_loop_record(noise=0.05, seed=3)
    got = identify_controller(rec.t, _setpoint(rec.t, setpoints=((20.0, 60.0),
                              (120.0, 45.0), (220.0, 55.0))), rec.y, rec.u)
    # SIMC on 2 e^{-s}/(10 s + 1): Kc = 10 / (2 * 2) = 2.5, Ti = min(10, 8) = 8; the
    # velocity form's integral is a backward sum, a sample from the forward one
    assert got.controller.kind == "PI"
    assert got.controller.Kc == pytest.approx(2.5, rel=0.05)
    assert got.controller.Ti == pytest.approx(8.0, rel=0.05)


def test_quantised_output_still_within_5_percent():
    """A controller output logged with 0.01 resolution: the settings still within 5 %, and
    the residual says something is not explained."""
    rec = loop_record("two_lags", "PID", noise=0.05, seed=1, loads=LOADS)
    u = np.round(rec.u, 2)
    got = identify_controller(rec.t, _setpoint(rec.t), rec.y, u)
    kc, ti, td = LOOP_TUNINGS["two_lags"]["PID"]
    assert got.controller.Kc == pytest.approx(kc, rel=0.05)
    assert got.controller.Ti == pytest.approx(ti, rel=0.05)
    assert got.controller.Td == pytest.approx(td, rel=0.05)
    assert got.residual_share > 1e-4


def test_refuses_logs_it_cannot_read():
    t = np.arange(100.0)
    with pytest.raises(ValueError, match="never changes"):
        identify_controller(t, np.ones(100), np.ones(100), np.ones(100))
    with pytest.raises(ValueError, match="uniformly"):
        identify_controller(t ** 1.1, np.ones(100), np.arange(100.0), np.ones(100))
    with pytest.raises(ValueError, match="same length"):
        identify_controller(t, np.ones(99), np.ones(100), np.ones(100))
