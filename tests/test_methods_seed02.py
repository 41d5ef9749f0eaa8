"""Seed 002 methods on plants with known truth: exact structures, noise, domains, and a
conformance check (STYLE.md 10).

Records come from :func:`pipeline.synth.step_record` (exact ZOH simulation) from a
nonzero operating point and go through segmentation (``event_data``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import pytest

from pipeline.errors import NotApplicable
from pipeline.events import EventData
from pipeline.methods import REGISTRY, identify
from pipeline.methods.base import normalised
from pipeline.methods.charts import STREJC_TABLE, strejc_row_exact
from pipeline.methods.harriott import harriott
from pipeline.methods.strejc import inflection_tangent, strejc_order
from pipeline.models import ProcessModel
from pipeline.record import make_record
from pipeline.segment import event_data
from pipeline.synth import step_record

SEED02 = ("viteckova1", "viteckova2", "latzel", "harriott", "smith", "strejc", "sundaresan")


def fo(T: float, delay: float = 0.0, K: float = 2.0) -> ProcessModel:
    return ProcessModel("first_order", {"K": K, "T": T, "delay": delay})


def nl(T: float, n: float, delay: float = 0.0, K: float = 2.0) -> ProcessModel:
    return ProcessModel("n_lags", {"K": K, "T": T, "n": n, "delay": delay})


def tl(T1: float, T2: float, delay: float = 0.0, K: float = 2.0) -> ProcessModel:
    return ProcessModel("two_lags", {"K": K, "T1": T1, "T2": T2, "delay": delay})


def so(zeta: float, wn: float, K: float = 2.0) -> ProcessModel:
    return ProcessModel("second_order", {"K": K, "zeta": zeta, "wn": wn, "delay": 0.0})


def make_event(plant: ProcessModel, *, after: float, dt: float, t0: float = 3.0,
               u: tuple[float, float] = (1.0, 2.0), y0: float = 5.0, noise: float = 0.0,
               seed: int = 0) -> EventData:
    """Step ``u[0] -> u[1]`` at ``t0`` from output ``y0``; ``noise`` is a fraction of the
    output change (white, seed-fixed)."""
    sd = noise * abs(plant.K * (u[1] - u[0]))
    rec = step_record(plant, u0=u[0], changes=[(t0, u[1])], t_end=t0 + after, dt=dt, y0=y0,
                      noise=sd, seed=seed)
    return event_data(rec.t, rec.u, rec.y)


def canonical(model: ProcessModel) -> dict[str, float]:
    p = {k: float(v) for k, v in model.params.items()}
    p.setdefault("delay", 0.0)
    if model.structure == "two_lags":
        p["T1"], p["T2"] = max(p["T1"], p["T2"]), min(p["T1"], p["T2"])
    return p


def assert_close(got: ProcessModel, want: ProcessModel, rel: float,
                 delay_abs: float | None = None) -> None:
    """Same structure; every parameter within ``rel`` (a zero delay within ``delay_abs``,
    default ``rel`` times the largest time constant)."""
    assert got.structure == want.structure, got
    g, w = canonical(got), canonical(want)
    scale = max(v for k, v in w.items() if k in ("T", "T1")) if "wn" not in w else 1.0
    for k, v in w.items():
        if k == "n":
            assert g[k] == v
        elif k == "delay" and (v == 0 or delay_abs is not None):
            assert abs(g[k] - v) <= (delay_abs if delay_abs is not None else rel * scale), \
                f"delay {g[k]:.5g} vs {v}"
        else:
            assert g[k] == pytest.approx(v, rel=rel), f"{k} = {g[k]:.5g}, expected {v:.5g}"


# -- exact structures, noise-free ----------------------------------------------------------


@dataclass(frozen=True)
class Exact:
    method: str
    plant: ProcessModel
    after: float
    dt: float = 1e-3
    expected: ProcessModel | None = None  # default: the plant itself
    rel: float = 0.001  # 0.5 % is the bar; 0.1 % where exact, so a mistyped constant fails
    delay_abs: float | None = None

    def __str__(self) -> str:
        return f"{self.method}-{self.plant.text(3)}"


EXACT = [
    Exact("latzel", nl(0.5, 2), 15),
    Exact("viteckova2", nl(0.5, 2), 15),
    Exact("viteckova1", fo(0.5), 10),
    Exact("viteckova1", fo(1.0, 0.3), 15, dt=0.01, delay_abs=0.01),  # within one sample
    Exact("viteckova2", nl(0.5, 2, 0.4), 15, dt=0.01, delay_abs=0.01),
    Exact("latzel", nl(0.4, 2.5), 15, rel=0.002),  # the non-integer row of Table 1
    Exact("smith", tl(1.0, 0.25), 20),
    Exact("smith", so(0.5, 2.0), 20),  # zeta < 1: the underdamped model (ERRATA #13)
    Exact("smith", tl(1.0, 0.02), 20),
    Exact("smith", fo(0.8), 15),  # the chart's first-order limit
    Exact("strejc", fo(0.5), 10, expected=fo(0.5066)),  # t72/1.2564 (paper Tab. 4: 0.507)
    # the 3-digit constants of eqs 23-24: T -0.7 %, delay +0.021 T
    Exact("sundaresan", fo(1.0, 1.0), 15, dt=0.01, rel=0.025),
]
# Table 1's alphas have 2-3 significant digits (0.069 for 0.0688 at n = 20: 0.52 %)
EXACT += [Exact("latzel", nl(0.2, n), 12 * n * 0.2 + 5, dt=2e-3, rel=0.006 if n == 20 else 0.002)
          for n in (3, 7, 12, 20)]
EXACT += [Exact("strejc", nl(0.3, n), 8 * n * 0.3 + 5, dt=1e-3) for n, _, _ in STREJC_TABLE[1:]]


@pytest.mark.parametrize("case", EXACT, ids=str)
def test_exact_structures(case: Exact) -> None:
    ev = make_event(case.plant, after=case.after, dt=case.dt)
    fit = identify(ev, case.method)
    assert fit.ok, fit.reason
    assert_close(fit.model, case.expected or case.plant, case.rel, case.delay_abs)


def test_harriott_refined_is_exact_on_two_lags() -> None:
    """ERRATA [S2] 10 refinement (exact x73 fixed point) removes the 1.3 rule's bias.
    (A plant with dead time keeps the bias of eq. 11's delay, Viteckova's equal-lag
    formula, which the refinement does not touch.)"""
    for plant in (tl(1.0, 0.25), tl(1.0, 0.6), tl(2.0, 0.1)):
        ev = make_event(plant, after=25, dt=1e-3)
        assert_close(harriott(ev, exact_x73=True).model, plant, 0.005, delay_abs=0.002)


def test_harriott_default_bias_is_the_1_3_rule() -> None:
    """Default Harriott on 2/((s+1)(0.25s+1)): the sum within 2 % (x73 = 1.278-1.309 vs
    1.3); the split carries the rest (-4 % / +8 %): a property of seed 002's method."""
    fit = identify(make_event(tl(1.0, 0.25), after=20, dt=1e-3), "harriott")
    p = canonical(fit.model)
    assert p["T1"] + p["T2"] == pytest.approx(1.25, rel=0.02)
    assert p["T1"] == pytest.approx(0.9565, abs=0.001)
    assert p["T2"] == pytest.approx(0.2703, abs=0.001)


# -- white noise of 1 % of the output change -------------------------------------------------

#: 10 ms samples, 30 s of settled baseline before the step (the segmenter's y0 averages
#: its last 10 %). Worst relative error over 40 seeds during development in the comment.
#: Smith's small constant is the most noise-sensitive parameter of the seven methods
#: (its split is ill-conditioned, ERRATA #27): at 1 % noise it needs ~1000 samples per
#: T1 to stay within 5 % (with 100 samples per T1 it scatters by up to 18 %).
NOISY = [
    Exact("latzel", nl(0.5, 5), 30, dt=0.01, rel=0.05),  # 0.8 %
    Exact("strejc", nl(0.5, 5), 30, dt=0.01, rel=0.05),  # 1.0 %, n = 5 in 40/40
    Exact("viteckova1", fo(1.0, 1.0), 15, dt=0.01, rel=0.05),  # 2.4 %
    Exact("sundaresan", fo(1.0, 1.0), 15, dt=0.01, rel=0.05),  # 3.5 %
    Exact("viteckova2", nl(0.5, 2, 1.0), 15, dt=0.01, rel=0.05),  # 2.5 %
    Exact("smith", tl(10.0, 2.5), 150, dt=0.01, rel=0.05),  # 4.0 %
]


@pytest.mark.parametrize("case", NOISY, ids=str)
def test_noisy_structures(case: Exact) -> None:
    ev = make_event(case.plant, after=case.after, dt=case.dt, t0=30.0, noise=0.01, seed=7)
    assert ev.noise > 0
    fit = identify(ev, case.method)
    assert fit.ok, fit.reason
    assert_close(fit.model, case.plant, case.rel, delay_abs=case.rel * case.plant.delay or None)


def test_noisy_harriott() -> None:
    """Refined Harriott within 5 % of the truth (worst 5.3 % over 40 seeds on T2: the chart
    reading is as ill-conditioned as Smith's); the default within 5 % of its own noise-free
    result (worst 2.9 %) since its bias is the method's (see above)."""
    plant = tl(10.0, 2.5)
    ev = make_event(plant, after=150, dt=0.01, t0=30.0, noise=0.01, seed=7)
    clean = make_event(plant, after=150, dt=0.01, t0=30.0)
    assert_close(harriott(ev, exact_x73=True).model, plant, 0.05, delay_abs=0.05)
    assert_close(harriott(ev).model, harriott(clean).model, 0.05, delay_abs=0.05)


def test_noisy_inflection_tangent_and_its_standard_error() -> None:
    """Tu/Tn on 2/(0.5s+1)^5 with 1 % noise: within 3 standard errors of the exact 0.4103,
    the se is realistic (0.005-0.02 at 10 ms) and the floor tolerance is 3 se."""
    ev = make_event(nl(0.5, 5), after=30, dt=0.01, t0=30.0, noise=0.01, seed=3)
    tau, h, sigma = normalised(ev)
    tg = inflection_tangent(tau, h, sigma)
    exact = strejc_row_exact(5)[1]
    assert 0.005 < tg.se < 0.02
    assert abs(tg.ratio - exact) < 3 * tg.se
    assert tg.t_i == pytest.approx(2.0, abs=0.1)  # (n-1) T
    fit = identify(ev, "strejc")
    assert fit.diagnostics["floor_tolerance"] == pytest.approx(3 * tg.se)


# -- domains and the ERRATA resolutions ----------------------------------------------------


@pytest.fixture(scope="module")
def five_lags() -> EventData:
    return make_event(nl(0.5, 5), after=25, dt=1e-3)


def test_smith_not_applicable_above_undamped_limit(five_lags: EventData) -> None:
    fit = identify(five_lags, "smith")
    assert fit.status == "not_applicable"
    assert fit.reason.startswith("t20/t60 = 0.5900 above what any second-order lag can "
                                 "produce (0.5551)")


def test_harriott_not_applicable_outside_chart() -> None:
    one = identify(make_event(fo(0.5), after=10, dt=1e-3), "harriott")
    assert one.status == "not_applicable" and "0.3956" in one.reason
    # a dominant dead time: Td (eq. 11) = 0.65 T, y(Td + 0.5 S) = 1 - e^-0.288 < 0.26
    fopdt = identify(make_event(fo(1.0, 1.0), after=25, dt=1e-3), "harriott")
    assert fopdt.status == "not_applicable" and "0.2493" in fopdt.reason


def test_viteckova_negative_delay_dropped_tau_kept() -> None:
    """ERRATA [S2] 6: V2 on a first-order lag computes a negative delay; it becomes 0 and
    tau stays 0.794 (t70 - t33) (paper Tab. 4: 0.318)."""
    fit = identify(make_event(fo(0.5), after=10, dt=1e-3), "viteckova2")
    d = fit.diagnostics
    assert d["delay_computed"] < 0 and d["delay_clipped"]
    assert fit.model.delay == 0.0
    assert fit.model.params["T"] == pytest.approx(0.794 * (d["t70"] - d["t33"]), rel=1e-12)
    assert fit.model.params["T"] == pytest.approx(0.318, abs=0.001)


def test_latzel_first_order_data_uses_nearest_row() -> None:
    """ERRATA [S2] 4: mu = 0.046 is below the table; the nearest row is n = 2."""
    fit = identify(make_event(fo(1.0), after=15, dt=1e-3), "latzel")
    assert fit.diagnostics["mu"] == pytest.approx(0.0458, abs=5e-4)
    assert fit.model.params["n"] == 2
    assert fit.model.params["T"] == pytest.approx(0.401, abs=0.002)


def test_strejc_floor_rule() -> None:
    """ERRATA [S2] 19: largest n with Tu/Tn(n) <= ratio + 1e-3 (not the nearest)."""
    assert strejc_order(0.4103)[0] == 5
    assert strejc_order(0.4095)[0] == 5
    assert strejc_order(0.4085)[0] == 4
    assert strejc_order(0.49)[0] == 5
    assert strejc_order(0.9)[0] == 10
    assert strejc_order(0.39, tol=0.03)[0] == 5


def test_strejc_cases_a_and_b(five_lags: EventData) -> None:
    """ERRATA [S2] 14: a double lag (Tu/Tn = 0.1036 < 0.104) is case a, two lags from
    Table 2 (Tab. 5 resolution 0.583, 0.427); the 5-lag is case b with the exact y_i."""
    two = identify(make_event(nl(0.5, 2), after=15, dt=1e-3), "strejc")
    assert two.diagnostics["case"] == "a"
    assert two.diagnostics["tu_tn_ratio"] == pytest.approx(0.1036, abs=2e-4)
    assert canonical(two.model)["T1"] == pytest.approx(0.583, abs=0.001)
    five = identify(five_lags, "strejc")
    assert five.diagnostics["case"] == "b" and five.model.params["n"] == 5
    assert five.diagnostics["y_i"] == pytest.approx(0.3712, abs=1e-4)
    assert five.diagnostics["tu_tn_ratio"] == pytest.approx(0.4103, abs=2e-4)


def test_diagnostics_are_absolute_times(five_lags: EventData) -> None:
    """Read points are absolute times (t0 + ...) and output levels, for the report."""
    fit = identify(five_lags, "latzel")
    d = fit.diagnostics
    assert d["t0"] == 3.0 and 3.0 < d["t10"] < d["t50"] < d["t90"]
    assert d["y50"] == pytest.approx(5.0 + 0.5 * 2.0, abs=1e-9)


# -- conformance: ok or not_applicable, never raises, never mutates ----------------------


@functools.cache
def conformance_events() -> dict[str, EventData]:
    return {
        "first_order": make_event(fo(1.0), after=12, dt=0.01),
        "underdamped": make_event(so(0.3, 2.0), after=25, dt=0.01),
        "five_lags": make_event(nl(0.5, 5), after=25, dt=0.01),
        "negative_step": make_event(nl(0.5, 5), after=25, dt=0.01, u=(2.0, 1.0)),
        "negative_gain": make_event(tl(1.0, 0.3, K=-3.0), after=20, dt=0.01),
        "noisy_fopdt": make_event(fo(1.0, 0.5), after=12, dt=0.01, noise=0.02, seed=1),
        "noisy_underdamped": make_event(so(0.3, 2.0), after=25, dt=0.01, noise=0.02),
        "truncated": make_event(fo(1.0), after=0.8, dt=0.01),
        "flat": flat_event(),
    }


def flat_event() -> EventData:
    """The input steps, the output does not move (only noise)."""
    t = np.arange(1301) * 0.01
    u = np.where(t >= 3.0, 2.0, 1.0)
    y = 5.0 + np.random.default_rng(0).normal(0.0, 0.01, t.size)
    rec = make_record(t, u, y, name="flat", source="<flat>")
    return event_data(rec.t, rec.u, rec.y)


CONFORMANCE = ("first_order", "underdamped", "five_lags", "negative_step", "negative_gain",
               "noisy_fopdt", "noisy_underdamped", "truncated", "flat")


@pytest.mark.parametrize("plant", CONFORMANCE)
@pytest.mark.parametrize("method", SEED02)
def test_conformance(method: str, plant: str) -> None:
    ev = conformance_events()[plant]
    before = {k: getattr(ev, k).copy() for k in ("t", "u", "y")}
    try:
        res = REGISTRY[method].func(ev)
    except NotApplicable as exc:
        assert exc.reason
        res = None
    for k, a in before.items():
        np.testing.assert_array_equal(getattr(ev, k), a)
    fit = identify(ev, method)
    assert fit.status in ("ok", "not_applicable"), fit.reason
    assert (res is None) == (fit.status == "not_applicable")
    if fit.ok:
        assert all(math.isfinite(v) for v in fit.model.params.values())
        assert np.all(np.isfinite(fit.model.unit_step(np.linspace(0, 10, 101))))
        assert fit.model.params["T" if "T" in fit.model.params else
                                ("T1" if "T1" in fit.model.params else "wn")] > 0
        assert fit.model.delay >= 0
    if plant == "flat":
        assert fit.status == "not_applicable"


@pytest.mark.parametrize("method", SEED02)
def test_negative_step_and_gain_mirror_the_positive(method: str) -> None:
    """A step down (or a negative gain) gives the same time constants as a step up."""
    up = identify(make_event(nl(0.5, 5), after=25, dt=0.01), method)
    down = identify(conformance_events()["negative_step"], method)
    assert up.status == down.status
    if up.ok:
        assert down.model.structure == up.model.structure
        for k, v in up.model.params.items():
            assert down.model.params[k] == pytest.approx(v, rel=1e-6, abs=1e-9), k
    plus = identify(make_event(tl(1.0, 0.3), after=20, dt=0.01), method)
    minus = identify(conformance_events()["negative_gain"], method)
    assert plus.status == minus.status
    if plus.ok:
        assert minus.model.params["K"] == pytest.approx(-3.0, rel=1e-6)
        for k, v in plus.model.params.items():
            if k != "K":
                assert minus.model.params[k] == pytest.approx(v, rel=1e-6, abs=1e-9), k
