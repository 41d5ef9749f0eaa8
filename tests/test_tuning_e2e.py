"""Tuning end to end from a noisy step test, checked on the TRUE plant (issue 28).

One member of each of Åström & Hägglund's benchmark families (2000; :data:`tests.
tuning_plants.TEST_PLANTS`) and the two other members the benchmark found fragile before
(P2 a=0.2, P5 T=5), a step test logged with 1 % white and AR(1) noise
(:func:`tests.tuning_plants.step_test`) over fixed seeds, ``pipeline.identify``, the SIMC
tuning of the recommended model, and the settings on the true plant (exact dead time,
Nyquist): the loop is stable in every seed, the true Ms is at most 2 in at least 95 % of
them, and no tuning is called "robust" when its true Ms exceeds 2 (:data:`KNOWN_FRAGILE`
would hold a member to its measured worst Ms instead; none is). The full Monte Carlo
(every member, 10 seeds or more) is ``benchmarks/tuning_e2e.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.models import ProcessModel
from pipeline.tuning import nominal_margins, tune
from tests.tuning_plants import (
    DU,
    MS_LIMIT,
    MS_SHARE,
    NOISE_KINDS,
    PLANTS,
    TEST_PLANTS,
    U0,
    Y0,
    claims,
    run_case,
    step_test,
    true_margins,
)

#: Fixed seeds (each seed draws the step time and the noise).
SEEDS = (2, 3)

#: Members whose true Ms exceeded 2 in more than 5 % of seeds in the benchmark (10 seeds,
#: ``benchmarks/tuning_e2e.py``), held to a measured bound instead of the claim. None
#: since the settings that are fragile or unstable over the model's intervals give way
#: to the fastest tau_c whose worst case keeps Ms at 2 (P2 a=0.2 and P5 T=5 under AR(1):
#: a dead time identified too short), and since P7's lag and lightly damped pair is a
#: structure (``lag_second_order``; before, every model was smooth and its SIMC PI had a
#: true Ms of 4.4-8.0).
KNOWN_FRAGILE: dict[str, float] = {}
MEMBERS = (*TEST_PLANTS, "P2 a=0.2", "P5 L=1 T=5")


@pytest.fixture(scope="module")
def rows() -> list[dict]:
    return [run_case(p, k, s) for p in MEMBERS for k in NOISE_KINDS for s in SEEDS]


def _brief(r: dict) -> str:
    p = ", ".join(f"{k}={v:.3g}" for k, v in (r.get("params") or {}).items())
    return (f"{r['plant']} {r['kind']} seed {r['seed']}: {r.get('method')} "
            f"{r.get('structure')}({p}) -> {r.get('controller')}, verdict {r.get('verdict')}, "
            f"Ms model {r.get('model_ms')}, worst {r.get('worst_ms')}, TRUE {r.get('true_ms')}")


def test_the_harness_logs_like_an_engineer_and_evaluates_the_true_plant():
    """The step test starts from a nonzero operating point, steps up after a baseline and
    back down, and settles; the true-plant check agrees with the model check when the
    model is the plant (P4 is a structure of the pipeline: SIMC's Ms 1.59, Skogestad
    2003 Table 3)."""
    p = PLANTS["P4 L=1 T=1"]
    t, u, y = step_test(p, "white", 3)
    up = np.flatnonzero(u > U0 + DU / 2)
    assert u[0] == U0 and u[-1] == U0 and up[0] > 0.15 * p.window / p.dt
    assert np.ptp(np.diff(t)) < 1e-9 and t[1] == pytest.approx(p.dt)
    tail = y[-int(0.2 * p.window / p.dt):]
    assert abs(np.mean(tail) - Y0) < 0.01 * DU
    top = y[up[-1] - int(0.2 * p.window / p.dt):up[-1]]
    assert abs(np.mean(top) - Y0 - p.gain * DU) < 0.01 * DU
    exact = ProcessModel("first_order", {"K": 1.0, "T": 1.0, "delay": 1.0})
    c = tune(exact).controller
    assert true_margins(p, c).ms == pytest.approx(nominal_margins(exact, c).ms, rel=1e-3)
    assert true_margins(p, c).ms == pytest.approx(1.59, abs=0.01)
    # a gain three times too high on the true plant: beyond its gain margin (about 3)
    assert not true_margins(p, c.with_gain(3.5)).stable


def test_every_step_test_gets_a_tuned_controller(rows):
    untuned = [r for r in rows if r.get("verdict") is None]
    assert not untuned, [(r["plant"], r["kind"], r["seed"], r.get("reason")) for r in untuned]


def test_the_true_loop_is_stable_in_every_seed(rows):
    bad = [_brief(r) for r in rows if not r.get("true_stable")]
    assert claims(rows)["stable"] == 1.0, bad


@pytest.mark.parametrize("member", MEMBERS)
def test_the_true_ms_is_at_most_2_in_95_percent_of_seeds(rows, member):
    """The claim, or for a known-fragile member its measured bound in every seed."""
    part = [r for r in rows if r["plant"] == member]
    if member in KNOWN_FRAGILE:
        worst = max(r.get("true_ms", math.inf) for r in part)
        assert worst <= KNOWN_FRAGILE[member], [_brief(r) for r in part]
        return
    assert claims(part)["ms_ok"] >= MS_SHARE, [_brief(r) for r in part
                                               if r.get("true_ms", math.inf) > MS_LIMIT]


def test_no_tuning_is_called_robust_when_its_true_ms_exceeds_2(rows):
    above = claims(rows)["robust_above"]
    assert not above, [_brief(r) for r in above]


def test_a_ring_behind_a_lag_is_modelled_and_the_smooth_models_say_they_miss_it(rows):
    """The must-flag case: P7's ring is missed by every smooth model, which says so
    (``oscillation_unmodelled``); the recommended model holds it (a lag and a lightly
    damped pair) and carries no such flag. Its twin: no other member (none rings) gets
    the flag or the structure."""
    ringing = [r for r in rows if r["plant"] == "P7 w0=3 zeta=0.1"]
    assert ringing
    for r in ringing:
        assert r["structure"] == "lag_second_order" and r["model_verdict"] == "ok", _brief(r)
        assert "oscillation_unmodelled" not in r["flags"], _brief(r)
        assert "oscillation_unmodelled" in r["smooth_flags"], _brief(r)
    calm = [r for r in rows if r["family"] != "P7"]
    assert calm and not [r for r in calm if "oscillation_unmodelled" in r.get("flags", ())]
    assert not [r for r in calm if r.get("structure") == "lag_second_order"]
