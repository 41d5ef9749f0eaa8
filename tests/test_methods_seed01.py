"""Seed 000 / 001 transient-analysis methods against known truth (STYLE.md 10).

Every case is a plant with known parameters, simulated exactly by ``pipeline.synth``,
segmented by ``event_data`` and identified through the registry. Noisy cases
run five fixed noise seeds and require every one of them inside the tolerance.

Noise levels: steps get white noise of standard deviation 1 % of the output change
``K du``; impulses 1 % of the peak output deviation.

Grids: the seeds do not state their sample times (ERRATA [S1] 12 infers 0.03 s for the
step example and 0.04 s for the impulse example). The second-order step example uses
0.01 s and an 8 s record: on the seed's own 3.3 s window the last samples (its y_ss) still
oscillate and bias zeta by +1.3 % (ERRATA [S1] 7). The noisy second-order impulse example
uses 0.01 s: at 0.04 s its zeta has a 1.6 % standard deviation, too close to 5 %.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import pytest
from scipy.optimize import brentq

from pipeline.events import EventData
from pipeline.methods import REGISTRY, identify
from pipeline.models import ProcessModel, second_order_step
from pipeline.segment import event_data
from pipeline.synth import pulse, response, step_record

SEEDS = (0, 1, 2, 3, 4)
#: The period of second_order_overshoot has a ~4 % standard deviation at 1 % noise: 5 seeds
#: can all pass by luck, 20 cannot (and all 20 pass with the proposed patch, std 0.7 %).
WN_SEEDS = tuple(range(20))

# -- plants -------------------------------------------------------------------------------
FO = ProcessModel("first_order", {"K": 2.5, "T": 7.0})  # issue 2
FO_DELAY = ProcessModel("first_order", {"K": 2.5, "T": 7.0, "delay": 0.3})
SO = ProcessModel("second_order", {"K": 0.25, "zeta": 0.31, "wn": 5.05})  # seed 001 step
SO_DELAY = ProcessModel("second_order", {"K": 0.25, "zeta": 0.31, "wn": 5.05, "delay": 0.3})
SO_NEG = ProcessModel("second_order", {"K": -1.5, "zeta": 0.5, "wn": 2.0})
SO_IMP = ProcessModel("second_order", {"K": 0.25, "zeta": 0.31, "wn": 5.16})  # seed 001 imp.
SO_IMP2 = ProcessModel("second_order", {"K": 2.0, "zeta": 0.2, "wn": 3.0})
FO_IMP = ProcessModel("first_order", {"K": 0.25, "T": 3.92})  # seed 001 impulse example
FO_LAG = ProcessModel("first_order", {"K": 2.0, "T": 4.0})


# -- event builders -----------------------------------------------------------------------
def step(model: ProcessModel, *, u0: float, u1: float, t0: float, y0: float, dt: float,
         t_end: float, noise: float = 0.0) -> Callable[[int], EventData]:
    """A step ``u0 -> u1`` at ``t0``; ``noise`` relative to the output change K du."""

    def make(seed: int) -> EventData:
        sd = noise * abs(model.K * (u1 - u0))
        rec = step_record(model, u0=u0, changes=[(t0, u1)], t_end=t_end, dt=dt, y0=y0,
                          noise=sd, seed=seed)
        return event_data(rec.t, rec.u, rec.y, initial_input=u0)

    return make


def impulse(model: ProcessModel, *, u0: float, t_on: float, width: float, height: float,
            y0: float, dt: float, t_end: float, noise: float = 0.0
            ) -> Callable[[int], EventData]:
    """A rectangular pulse of ``height`` for ``width`` s (area = height x width) from the
    baseline ``u0``; ``noise`` relative to the peak output deviation."""

    def make(seed: int) -> EventData:
        t = np.arange(int(round(t_end / dt)) + 1) * dt
        u = pulse(t, u0, t_on, width, height)
        y = response(model, t, u, u0, y0)
        if noise:
            sd = noise * float(np.max(np.abs(y - y0)))
            y = y + np.random.default_rng(seed).normal(0.0, sd, y.size)
        return event_data(t, u, y, initial_input=u0)

    return make


# -- expected values that carry a documented bias ------------------------------------------
def pov_wn_expected(zeta: float, wn: float, band: float = 0.01, factor: float = 5.0
                    ) -> float:
    """What ``wn = 5/(zeta t_s)`` gives on the exact response (seed 000, ERRATA [S0] 3).

    The extrema of the unit step response sit at m pi/wd with |h - 1| = M^m; the last one
    outside the band is followed by the exact settling time, the root of |h - 1| = band.
    """
    wd = wn * math.sqrt(1 - zeta**2)
    M = math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))
    m = math.floor(math.log(band) / math.log(M))
    f = lambda t: abs(second_order_step(np.array([t]), zeta, wn)[0] - 1) - band  # noqa: E731
    ts = brentq(f, m * math.pi / wd, (m + 1) * math.pi / wd)
    return factor / (zeta * ts)


def fo_peak_gain(K: float, T: float, width: float) -> float:
    """``y_max T / area`` for a rectangular pulse: the peak is K (A/w)(1 - e^{-w/T})."""
    return K * T / width * -math.expm1(-width / T)


WN_POV = pov_wn_expected(0.31, 5.05)  # 5.717: +13.2 % over 5.05, the t_s = 5 tau bias
WN_POV_NEG = pov_wn_expected(0.5, 2.0)


# -- the case table -----------------------------------------------------------------------
@dataclass(frozen=True)
class Expect:
    """``key``: a model parameter, or ``diag.<name>`` for a diagnostic. Tolerance ``rel``
    (relative) or ``abs`` (absolute, e.g. one sample of dead time)."""

    key: str
    truth: float
    rel: float | None = None
    abs: float | None = None


@dataclass(frozen=True)
class Case:
    id: str
    method: str
    make: Callable[[int], EventData]
    expect: tuple[Expect, ...]
    seeds: tuple[int, ...] = (0,)
    xfail: str | None = None


def rel(tol: float, **truth: float) -> tuple[Expect, ...]:
    return tuple(Expect(k, v, rel=tol) for k, v in truth.items())


FO_UP = dict(u0=1.5, u1=3.5, t0=13.7, y0=-4.0, dt=0.05, t_end=13.7 + 70)
FO_DOWN = dict(FO_UP, u0=3.5, u1=1.5)
SO_UP = dict(u0=0.0, u1=4.0, t0=1.3, y0=0.7, dt=0.01, t_end=1.3 + 8)
SO_DOWN = dict(SO_UP, u0=4.0, u1=0.0)
IMP_SO_SEED = dict(u0=2.0, t_on=1.6, y0=0.5)  # seed 001: u0 = 2, y0 = K u0 = 0.5
IMP_FO_SEED = dict(u0=0.5, t_on=8.84, y0=0.125, t_end=48.0)  # ERRATA [S1] 3: y0 = K u0

CASES: list[Case] = [
    # 1. issue 2: the existing step methods, nonzero u0, y0, t0, both directions
    Case("first_order/issue2/up", "first_order", step(FO, **FO_UP),
         rel(0.005, K=2.5, T=7.0)),
    Case("first_order/issue2/down", "first_order", step(FO, **FO_DOWN),
         rel(0.005, K=2.5, T=7.0)),
    Case("first_order/issue2/up/noisy", "first_order", step(FO, **FO_UP, noise=0.01),
         rel(0.02, K=2.5, T=7.0), SEEDS),
    Case("first_order/issue2/down/noisy", "first_order", step(FO, **FO_DOWN, noise=0.01),
         rel(0.02, K=2.5, T=7.0), SEEDS),
    Case("second_order_overshoot/issue2/up", "second_order_overshoot", step(SO, **SO_UP),
         rel(0.01, K=0.25, zeta=0.31, wn=5.05)),
    Case("second_order_overshoot/issue2/down", "second_order_overshoot",
         step(SO, **SO_DOWN), rel(0.01, K=0.25, zeta=0.31, wn=5.05)),
    Case("second_order_overshoot/issue2/up/noisy", "second_order_overshoot",
         step(SO, **SO_UP, noise=0.01), rel(0.03, K=0.25, zeta=0.31), SEEDS),
    Case("second_order_overshoot/issue2/down/noisy", "second_order_overshoot",
         step(SO, **SO_DOWN, noise=0.01), rel(0.03, K=0.25, zeta=0.31), SEEDS),
    Case("second_order_overshoot/issue2/up/noisy/wn", "second_order_overshoot",
         step(SO, **SO_UP, noise=0.01), rel(0.03, wn=5.05), WN_SEEDS),
    Case("second_order_overshoot/issue2/down/noisy/wn", "second_order_overshoot",
         step(SO, **SO_DOWN, noise=0.01), rel(0.03, wn=5.05), WN_SEEDS),
    # 2. exact structure, noise-free, 0.5 %
    Case("first_order_two_point/lag", "first_order_two_point", step(FO, **FO_UP),
         rel(0.005, K=2.5, T=7.0) + (Expect("delay", 0.0, abs=0.05),)),
    Case("first_order_two_point/lag/down", "first_order_two_point", step(FO, **FO_DOWN),
         rel(0.005, K=2.5, T=7.0)),
    Case("first_order_two_point/lag/noisy", "first_order_two_point",
         step(FO, **FO_UP, noise=0.01), rel(0.02, K=2.5, T=7.0), SEEDS),
    Case("first_order_two_point/delay", "first_order_two_point", step(FO_DELAY, **FO_UP),
         rel(0.005, K=2.5, T=7.0) + (Expect("delay", 0.3, abs=0.05),)),
    Case("second_order_overshoot/negative_gain", "second_order_overshoot",
         step(SO_NEG, u0=2.0, u1=5.0, t0=3.0, y0=10.0, dt=0.01, t_end=3.0 + 15),
         rel(0.005, K=-1.5, zeta=0.5, wn=2.0)),
    Case("second_order_pov/exact", "second_order_pov", step(SO, **SO_UP),
         rel(0.005, K=0.25, zeta=0.31, wn=WN_POV)),
    Case("second_order_pov/down", "second_order_pov", step(SO, **SO_DOWN),
         rel(0.005, K=0.25, zeta=0.31, wn=WN_POV)),
    Case("second_order_pov/negative_gain", "second_order_pov",
         step(SO_NEG, u0=2.0, u1=5.0, t0=3.0, y0=10.0, dt=0.01, t_end=3.0 + 15),
         rel(0.005, K=-1.5, zeta=0.5, wn=WN_POV_NEG)),
    Case("second_order_pov/noisy/zeta", "second_order_pov", step(SO, **SO_UP, noise=0.01),
         rel(0.03, K=0.25, zeta=0.31), SEEDS),
    Case("second_order_impulse/exact", "second_order_impulse",
         impulse(SO_IMP, **IMP_SO_SEED, width=0.01, height=100.0, dt=0.01, t_end=8.0),
         rel(0.005, K=0.25, zeta=0.31, wn=5.16)),
    Case("second_order_impulse/negative_pulse", "second_order_impulse",
         impulse(SO_IMP2, u0=1.0, t_on=2.0, width=0.02, height=-10.0, y0=-3.0, dt=0.01,
                 t_end=2.0 + 12),
         rel(0.005, K=2.0, zeta=0.2, wn=3.0)),
    # a 0.2 s pulse of height 3 on T = 4 s: area 0.6. After the pulse the lag decays as a
    # pure exponential, so T is exact whatever the width (only the 0.368 level: -0.03 %);
    # the area ratio is exact for any pulse; y_max T / A is biased by ~ -w/(2T) = -2.5 %.
    Case("first_order_impulse/pulse_0.2s", "first_order_impulse",
         impulse(FO_LAG, u0=0.0, t_on=1.0, width=0.2, height=3.0, y0=0.0, dt=0.01,
                 t_end=41.0),
         rel(0.005, K=2.0, T=4.0)
         + rel(0.005, **{"diag.K_area": 2.0, "diag.K_peak": fo_peak_gain(2.0, 4.0, 0.2),
                         "diag.K_peak_rect": 2.0})),
    Case("first_order_impulse/negative_pulse_nonzero_ic", "first_order_impulse",
         impulse(FO_LAG, u0=2.0, t_on=1.0, width=0.2, height=-3.0, y0=4.0, dt=0.01,
                 t_end=41.0),
         rel(0.005, K=2.0, T=4.0, **{"diag.K_steady_state": 2.0})),
    # a pulse as long as half the time constant: T and K_area still exact, K_peak -21 %
    Case("first_order_impulse/long_pulse", "first_order_impulse",
         impulse(FO_LAG, u0=0.0, t_on=1.0, width=2.0, height=0.5, y0=0.0, dt=0.01,
                 t_end=45.0),
         rel(0.005, K=2.0, T=4.0, **{"diag.K_peak": fo_peak_gain(2.0, 4.0, 2.0)})),
    # dead time 0.3 s, within one sample
    Case("first_order/delay", "first_order",
         step(FO_DELAY, **dict(FO_UP, dt=0.01)),
         rel(0.005, K=2.5, T=7.0) + (Expect("delay", 0.3, abs=0.01),)),
    Case("first_order/delay/dt0.05", "first_order", step(FO_DELAY, **FO_UP),
         rel(0.005, K=2.5, T=7.0) + (Expect("delay", 0.3, abs=0.05),)),
    Case("second_order_overshoot/delay", "second_order_overshoot",
         step(SO_DELAY, **SO_UP),
         rel(0.005, K=0.25, zeta=0.31, wn=5.05) + (Expect("delay", 0.3, abs=0.01),)),
    # 3. the seeds' worked examples, from their stated models
    Case("seed001/step", "second_order_overshoot",
         step(SO, u0=0.0, u1=4.0, t0=0.0, y0=0.0, dt=0.01, t_end=8.0),
         rel(0.01, K=0.25, zeta=0.31, wn=5.05)),
    Case("seed001/step/noisy", "second_order_overshoot",
         step(SO, u0=0.0, u1=4.0, t0=0.0, y0=0.0, dt=0.01, t_end=8.0, noise=0.01),
         rel(0.05, K=0.25, zeta=0.31), SEEDS),
    Case("seed001/step/noisy/wn", "second_order_overshoot",
         step(SO, u0=0.0, u1=4.0, t0=0.0, y0=0.0, dt=0.01, t_end=8.0, noise=0.01),
         rel(0.05, wn=5.05), WN_SEEDS),
    Case("seed001/impulse2", "second_order_impulse",  # the seed's grid: 130 x 0.04 s
         impulse(SO_IMP, **IMP_SO_SEED, width=0.04, height=25.0, dt=0.04, t_end=5.2),
         rel(0.01, K=0.25, zeta=0.31, wn=5.16, **{"diag.K_steady_state": 0.25})),
    Case("seed001/impulse2/noisy", "second_order_impulse",
         impulse(SO_IMP, **IMP_SO_SEED, width=0.01, height=100.0, dt=0.01, t_end=5.2,
                 noise=0.01),
         rel(0.05, K=0.25, zeta=0.31, wn=5.16, **{"diag.K_steady_state": 0.25}), SEEDS),
    Case("seed001/impulse1", "first_order_impulse",
         impulse(FO_IMP, **IMP_FO_SEED, width=0.04, height=25.0, dt=0.04),
         rel(0.01, K=0.25, T=3.92, **{"diag.K_steady_state": 0.25})),
    Case("seed001/impulse1/noisy", "first_order_impulse",
         impulse(FO_IMP, **IMP_FO_SEED, width=0.04, height=25.0, dt=0.04, noise=0.01),
         rel(0.05, K=0.25, T=3.92, **{"diag.K_steady_state": 0.25}), SEEDS),
    # 4. zero initial conditions: no steady-state gain, K from the peak and from the areas
    Case("zero_ic/impulse1", "first_order_impulse",
         impulse(FO_IMP, u0=0.0, t_on=2.0, width=0.02, height=50.0, y0=0.0, dt=0.02,
                 t_end=42.0),
         rel(0.005, K=0.25, T=3.92, **{"diag.K_area": 0.25,
                                      "diag.K_peak": fo_peak_gain(0.25, 3.92, 0.02)})
         + rel(0.01, **{"diag.K_peak": 0.25})),
    Case("zero_ic/impulse1/noisy", "first_order_impulse",
         impulse(FO_IMP, u0=0.0, t_on=2.0, width=0.02, height=50.0, y0=0.0, dt=0.02,
                 t_end=42.0, noise=0.01),
         rel(0.05, K=0.25, T=3.92, **{"diag.K_area": 0.25, "diag.K_peak": 0.25}), SEEDS),
    Case("zero_ic/impulse2", "second_order_impulse",
         impulse(SO_IMP, u0=0.0, t_on=1.0, width=0.01, height=100.0, y0=0.0, dt=0.01,
                 t_end=8.0),
         rel(0.005, K=0.25, zeta=0.31, wn=5.16,
             **{"diag.K_peak": 0.25, "diag.K_lobes": 0.25, "diag.K_area": 0.25})),
    Case("zero_ic/impulse2/noisy", "second_order_impulse",
         impulse(SO_IMP, u0=0.0, t_on=1.0, width=0.01, height=100.0, y0=0.0, dt=0.01,
                 t_end=8.0, noise=0.01),
         rel(0.05, K=0.25, zeta=0.31, wn=5.16,
             **{"diag.K_peak": 0.25, "diag.K_lobes": 0.25}), SEEDS),
]


def _value(fit, key: str) -> float:
    if key.startswith("diag."):
        return fit.diagnostics[key[5:]]
    return fit.model.params[key]


def _params() -> list:
    return [pytest.param(c, id=c.id,
                         marks=[pytest.mark.xfail(strict=True, reason=c.xfail)] if c.xfail
                         else [])
            for c in CASES]


@pytest.mark.parametrize("case", _params())
def test_recovers_known_plant(case: Case) -> None:
    for seed in case.seeds:
        fit = identify(case.make(seed), case.method)
        assert fit.status == "ok", f"seed {seed}: {fit.status}: {fit.reason}"
        for e in case.expect:
            got = _value(fit, e.key)
            if e.abs is not None:
                assert abs(got - e.truth) <= e.abs, (
                    f"seed {seed}: {e.key} = {got:.6g}, truth {e.truth:.6g} +- {e.abs}")
            else:
                err = got / e.truth - 1
                assert abs(err) <= e.rel, (
                    f"seed {seed}: {e.key} = {got:.6g}, truth {e.truth:.6g} "
                    f"({err:+.2%}, tolerance {e.rel:.1%})")


def test_pov_bias_is_the_documented_one() -> None:
    """The t_s = 5 tau rule over-reads wn: +13.2 % for zeta = 0.31 on exact data; the
    envelope alone would give 5/ln(1/(0.01 sqrt(1 - zeta^2))) - 1 = +7.4 % (ERRATA [S0] 3)."""
    assert WN_POV / 5.05 - 1 == pytest.approx(0.132, abs=0.001)
    env = math.log(1 / (0.01 * math.sqrt(1 - 0.31**2)))
    assert 5 / env - 1 == pytest.approx(0.074, abs=0.001)
    fit = identify(step(SO, **SO_UP)(0), "second_order_pov")
    assert fit.diagnostics["wn_period"] == pytest.approx(5.05, rel=0.005)


def test_impulse_gain_choice_is_reported() -> None:
    fit = identify(impulse(SO_IMP, **IMP_SO_SEED, width=0.01, height=100.0, dt=0.01,
                           t_end=5.2, noise=0.01)(0), "second_order_impulse")
    d = fit.diagnostics
    assert d["K_choice"] in ("K_area", "K_lobes")
    assert fit.model.params["K"] == d[d["K_choice"]]
    # on a 3.6 s noisy window the whole-response integral is the worse conditioned one
    assert d["K_choice"] == "K_lobes" and d["K_area_se"] > d["K_lobes_se"]
    for key in ("K_steady_state", "K_peak", "K_lobes", "K_area", "A_plus", "A_minus",
                "t01", "t02", "period_peaks", "period_crossings"):
        assert d[key] is not None


# -- domain: not_applicable with a reason, never an exception ------------------------------
SLOW = ProcessModel("first_order", {"K": 1.0, "T": 500.0})
LIGHT = ProcessModel("second_order", {"K": 1.0, "zeta": 0.02, "wn": 3.0})

def flat(kind: str) -> Callable[[int], EventData]:
    """An input step or pulse with an output that does not respond at all."""

    def make(seed: int) -> EventData:
        t = np.arange(601) * 0.1
        u = pulse(t, 0.0, 1.0, 0.5, 1.0) if kind == "impulse" else np.where(t >= 1.0, 1.0, 0.0)
        return event_data(t, u, np.full(t.size, 3.0), initial_input=0.0)

    return make


NOT_APPLICABLE = [
    ("first_order_two_point", flat("step"), "did not change"),
    ("second_order_pov", step(FO, **FO_UP), "overshoot"),
    ("second_order_pov", step(LIGHT, u0=0, u1=1, t0=1, y0=0, dt=0.01, t_end=11),
     "settle"),
    ("second_order_overshoot", step(FO, **FO_UP), "overshoot"),
    ("second_order_impulse",
     impulse(FO_LAG, u0=0, t_on=1, width=0.2, height=3, y0=0, dt=0.01, t_end=41),
     "baseline crossings"),
    ("first_order_impulse",
     impulse(SLOW, u0=0, t_on=1, width=0.5, height=1, y0=0, dt=0.1, t_end=60),
     "36.8"),
    ("first_order_impulse", flat("impulse"), "no measurable"),
    ("second_order_impulse", flat("impulse"), "no measurable"),
    ("first_order_impulse", step(FO, **FO_UP), "needs an impulse event"),
    ("first_order_two_point",
     impulse(FO_LAG, u0=0, t_on=1, width=0.2, height=3, y0=0, dt=0.01, t_end=41),
     "needs a step event"),
]


@pytest.mark.parametrize(("method", "make", "reason"), NOT_APPLICABLE,
                         ids=[f"{m}/{r}" for m, _, r in NOT_APPLICABLE])
def test_not_applicable_with_reason(method: str, make, reason: str) -> None:
    fit = identify(make(0), method)
    assert fit.status == "not_applicable", (fit.status, fit.reason, fit.model)
    assert reason in fit.reason


MINE = ("first_order_two_point", "first_order_impulse", "second_order_impulse",
        "second_order_pov")


@pytest.mark.parametrize("method", MINE)
def test_conformance_never_raises_never_mutates(method: str) -> None:
    """Every event shape (steps, pulses, flat, noise only, truncated) gives ok or
    not_applicable with a reason, and the event's arrays are left untouched."""
    assert method in REGISTRY
    rng = np.random.default_rng(7)
    events = [
        step(FO, **FO_UP)(0), step(SO, **SO_DOWN, noise=0.05)(0),
        impulse(SO_IMP, **IMP_SO_SEED, width=0.04, height=25.0, dt=0.04, t_end=5.2)(0),
        impulse(FO_LAG, u0=0, t_on=1, width=0.2, height=-3, y0=0, dt=0.01, t_end=41)(0),
    ]
    base = events[2]
    events += [
        replace(base, y=np.full(base.y.size, 0.5)),  # no response at all
        replace(base, y=base.y + rng.normal(0, 1.0, base.y.size)),  # drowned in noise
        replace(base, t=base.t[:45], u=base.u[:45], y=base.y[:45]),  # cut after the peak
        replace(base, area=0.0),
    ]
    for ev in events:
        before = [a.copy() for a in (ev.t, ev.u, ev.y)]
        fit = identify(ev, method)
        assert fit.status in ("ok", "not_applicable"), (fit.status, fit.reason)
        if fit.status == "not_applicable":
            assert fit.reason
        for a, b in zip(before, (ev.t, ev.u, ev.y), strict=True):
            np.testing.assert_array_equal(a, b)
