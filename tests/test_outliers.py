"""Single-sample outliers (issue 27 item 6): a sensor glitch is named (``outlier_samples``)
and ignored by the fits, not called a drift or a misfit; nothing else is ever taken for
one (the twins: Monte Carlo plants under white, AR(1) and 1/f noise, a fast plant's
answer to a one-sample pulse, a ring sampled six times a period, a quantised sensor,
the real logs)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

import pipeline
from pipeline.models import ProcessModel
from pipeline.outliers import find_outliers
from pipeline.synth import step_record
from pipeline.synth.montecarlo import NOISE_KINDS, PLANTS, Condition, mc_record
from tests.conftest import have_mirror

TRUTH = ProcessModel("first_order", {"K": 2.0, "T": 5.0, "delay": 0.5})


def _record(seed: int):
    return step_record(TRUTH, u0=1.0, changes=[(10.0, 3.0), (60.0, 1.0)], t_end=110.0,
                       dt=0.1, y0=6.0, noise=0.02, seed=seed)


@pytest.mark.parametrize("rows", [[0], [300], [300, 301], [0, 450, 800]])
def test_a_glitch_is_named_and_the_fits_do_not_see_it(rows):
    """One 0.0 read in a log near 6 (at the first row, mid-response, a run of two, three
    of them): the gain stays within 0.5 % of the truth and of the clean record's fit, the
    refinement is not flagged for misfit, and the flag names the first glitch."""
    rec = _record(3)
    clean = pipeline.analyse(rec).recommended.model.K
    y = rec.y.copy()
    y[rows] = 0.0
    res = pipeline.identify(rec.t, rec.u, y)
    (flag,) = [f for f in res.flags if f.code == "outlier_samples"]
    assert flag.severity == "info" and flag.values["samples"] == len(rows)
    assert flag.values["first_time"] == pytest.approx(rec.t[rows[0]])
    assert f"t = {rec.t[rows[0]]:.3g} s reads 0 where" in flag.message
    lsq = next(f for f in res.fits if f.method == "lsq_first_order" and f.event == 0)
    assert lsq.model.K == pytest.approx(2.0, rel=0.005)
    assert lsq.model.K == pytest.approx(clean, rel=0.002)
    assert not {"residuals_not_white", "baseline_not_steady"} & {x.code for x in lsq.flags}
    assert res.record.y[rows[0]] != 0.0  # replaced for the analysis


@pytest.mark.parametrize("kind", NOISE_KINDS)
def test_no_monte_carlo_sample_is_an_outlier(kind):
    """Every Monte Carlo plant (including the underdamped and the inverse response),
    noise 0.5 % and 2 %, windows 3 T and 6 T, 3 seeds: no outlier."""
    found = []
    for name, plant in PLANTS.items():
        for level in (0.005, 0.02):
            for window in (3.0, 6.0):
                for seed in range(3):
                    rec = mc_record(plant, Condition(kind=kind, level=level,
                                                     window=window), seed)
                    idx, _ = find_outliers(rec.u, rec.y)
                    if idx.size:
                        found.append((name, level, window, seed, idx[:3].tolist()))
    assert not found, found


def test_a_fast_plants_answer_to_a_one_sample_pulse_is_kept():
    t = np.arange(0.0, 50.0, 0.1)
    u = np.zeros_like(t)
    u[[100, 300]] = 1.0  # one-sample pulses
    y = np.zeros_like(t)
    y[[101, 301]] = 0.8  # a plant faster than the sampling answers within one sample
    y += np.random.default_rng(0).normal(0.0, 0.01, t.size)
    idx, _ = find_outliers(u, y)
    assert idx.size == 0


def test_a_ring_sampled_six_times_a_period_and_a_quantised_sensor_are_kept():
    t = np.arange(0.0, 200.0, 1.0)
    u = np.where(t >= 20.0, 1.0, 0.0)
    wn = 2 * np.pi / 6.0
    _, y, _ = signal.lsim(([wn**2], [1.0, 0.2 * wn, wn**2]), u, t)
    assert find_outliers(u, y + np.random.default_rng(1).normal(0, 0.01, t.size))[0].size == 0
    q = np.round(5.0 + 3.0 * (1 - np.exp(-np.clip(t - 20.0, 0, None) / 30.0))
                 + np.random.default_rng(2).normal(0.0, 0.05, t.size), 1)
    assert find_outliers(u, q)[0].size == 0


@pytest.mark.skipif(not have_mirror(), reason="needs the dataset mirror")
def test_no_real_log_has_an_outlier():
    import os
    import sys
    from pathlib import Path

    from tests.conftest import SHARED

    sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
    import real_logs

    root = Path(os.environ.get("PIPELINE_DATASETS_MIRROR") or str(SHARED))
    for name, (rel, kw) in real_logs.LOGS.items():
        rec = pipeline.load(root / rel, **kw)
        assert find_outliers(rec.u, rec.y)[0].size == 0, name


def test_a_delayed_answer_to_a_pulse_is_kept():
    """Review: a fast plant (T 0.05 s on a 0.1 s grid) with a 0.6 s dead time answers a
    one-sample pulse six samples late with a one- or two-sample spike; it is the plant,
    not a glitch, and the gain stays the plant's."""
    t = np.arange(0.0, 50.0, 0.1)
    u = np.zeros_like(t)
    u[[100, 300]] = 1.0
    y = np.zeros_like(t)
    for k in (100, 300):  # the held pulse through the lag, sampled: 2 (1 - e^-2), then e^-2 of it
        y[k + 6], y[k + 7] = 2.0 * (1 - np.exp(-2.0)), 2.0 * (1 - np.exp(-2.0)) * np.exp(-2.0)
    y += np.random.default_rng(0).normal(0.0, 0.002, t.size)
    idx, _ = find_outliers(u, y)
    assert idx.size == 0
