"""Seed 002 (Jakoubek) Tables 4-8 reproduced: five systems (eqs 26-30), seven methods.

Each system (gain 2) is simulated noise-free at 1 ms for 25 s after a step from a
nonzero operating point (u 1 -> 2 at t0 = 3 s, y0 = 5) by the shared builders
(``tests.builders.jakoubek``), segmented like any log, and identified. The table keeps
its own shape (printed vs exact values, ERRATA notes; the other methods' cases are in
``tests/cases.py``). One parametrised test runs it (STYLE.md 10):

* ``match``: the paper's printed parameters are reproduced within 2 % (0.01 s for a time
  below 0.5 s; n exactly).
* ``exact``: ERRATA [S2] marks the printed row as a chart-reading error (Harriott
  Tab. 5-8, Smith Tab. 4-6, #27) or a wrong row (Strejc Tab. 5-8, #25/#26; Viteckova
  Tab. 6, #24). The case states both the printed and the exact value; we must return
  the exact one (0.5 % / 0.002 s) and its ISE against the true system must be lower than
  the ISE of the printed model (ISE of the unit-input-step responses over 20 s,
  ERRATA #23).
* ``n/a``: not applicable, with the reason (Harriott Tab. 4, ERRATA #11; Smith Tab. 7/8,
  #13).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
import pytest

from pipeline.events import EventData
from pipeline.methods import identify
from pipeline.methods.harriott import harriott
from pipeline.metrics import ise
from pipeline.models import ProcessModel
from pipeline.synth import JAKOUBEK_LAGS, lag_chain_step
from tests.builders import jakoubek

DT = 1e-3
ISE_GRID = np.arange(20001) * DT  # 20 s after the step (ERRATA [S2] 23)

#: eq. (30): five distinct lags.
LAGS5 = JAKOUBEK_LAGS[5]

#: eqs (26)-(29) as models; eq. (30) has no structure in models.py.
SYSTEMS: dict[int, ProcessModel] = {
    1: ProcessModel("first_order", {"K": 2.0, "T": 0.5}),
    2: ProcessModel("n_lags", {"K": 2.0, "T": 0.5, "n": 2}),
    3: ProcessModel("two_lags", {"K": 2.0, "T1": 1.0, "T2": 0.1}),
    4: ProcessModel("n_lags", {"K": 2.0, "T": 0.5, "n": 5}),
}


def true_step(system: int, t: np.ndarray) -> np.ndarray:
    return lag_chain_step(LAGS5, t, K=2.0) if system == 5 else SYSTEMS[system].unit_step(t)


@functools.cache
def event(system: int) -> EventData:
    """The segmented step event of system ``system`` (cached: built once per run)."""
    return jakoubek(system, dt=DT)


def F(T: float, delay: float = 0.0) -> ProcessModel:
    return ProcessModel("first_order", {"K": 2.0, "T": T, "delay": delay})


def N(T: float, n: float, delay: float = 0.0) -> ProcessModel:
    return ProcessModel("n_lags", {"K": 2.0, "T": T, "n": n, "delay": delay})


def L(T1: float, T2: float, delay: float = 0.0) -> ProcessModel:
    return ProcessModel("two_lags", {"K": 2.0, "T1": T1, "T2": T2, "delay": delay})


@dataclass(frozen=True)
class Case:
    table: int
    method: str
    kind: str  # "match" | "exact" | "n/a"
    paper: ProcessModel | None  # as printed (None: "doesn't suit")
    exact: ProcessModel | None = None  # kind "exact": the right value
    errata: str = ""
    reason: str = ""  # kind "n/a": part of the reason
    ise_check: str = "lower"  # "lower" | "refined_lower" (see Tab. 5 Harriott)
    extra: dict = field(default_factory=dict)

    @property
    def system(self) -> int:
        return self.table - 3

    def __str__(self) -> str:
        return f"tab{self.table}-{self.method}"


CASES: list[Case] = [
    # Tab. 4: 2/(0.5s+1)
    Case(4, "viteckova1", "match", F(0.499, 0.0013)),
    Case(4, "sundaresan", "match", F(0.496, 0.0053)),
    Case(4, "strejc", "match", F(0.507)),
    Case(4, "harriott", "n/a", L(0.2, 0.304), errata="#11",
         reason="outside Harriott's range"),
    Case(4, "smith", "exact", L(0.373, 0.0057), F(0.5), errata="#13, #27"),
    Case(4, "latzel", "match", N(0.201, 2)),
    Case(4, "viteckova2", "match", N(0.318, 2)),
    # Tab. 5: 2/(0.5s+1)^2
    Case(5, "latzel", "match", N(0.5, 2)),
    Case(5, "viteckova2", "match", N(0.5, 2)),
    # exact chart: y(0.5 S) = 0.2623 (< 0.2642 by the 1.3 rule's bias) -> r = 0.5; the
    # printed split happens to offset the 1.3 rule's -0.5 % on S, so only the refined
    # fixed point (ERRATA #10) beats the printed model's ISE (2.45e-5 vs ours 4.05e-5).
    Case(5, "harriott", "exact", L(0.487, 0.509), L(0.4974, 0.4974), errata="#27",
         ise_check="refined_lower"),
    Case(5, "viteckova1", "match", F(0.784, 0.276)),
    Case(5, "smith", "exact", L(0.743, 0.350), L(0.5, 0.5), errata="#27"),
    Case(5, "sundaresan", "match", F(0.722, 0.316)),
    Case(5, "strejc", "exact", F(1.01), L(0.583, 0.427), errata="#25"),
    # Tab. 6: 2/((0.1s+1)(s+1))
    Case(6, "harriott", "exact", L(0.975, 0.115), L(0.9801, 0.1082), errata="#27"),
    Case(6, "viteckova1", "exact", F(0.1, 0.105), F(1.002, 0.104), errata="#24"),
    Case(6, "smith", "exact", L(1.03, 0.0932), L(1.0, 0.1), errata="#27"),
    Case(6, "sundaresan", "match", F(0.993, 0.117)),
    Case(6, "strejc", "exact", F(1.1), L(0.996, 0.101), errata="#25"),
    Case(6, "latzel", "match", N(0.486, 2)),
    Case(6, "viteckova2", "match", N(0.639, 2)),
    # Tab. 7: 2/(0.5s+1)^5
    Case(7, "latzel", "match", N(0.501, 5)),
    Case(7, "viteckova2", "match", N(0.838, 2, 0.906)),
    # sum 1.652 and r = 0.40 (ERRATA #9, #27)
    Case(7, "harriott", "exact", L(0.437, 1.22, 0.906), L(0.9912, 0.6606, 0.9099),
         errata="#9, #27"),
    Case(7, "viteckova1", "match", F(1.31, 1.37)),
    Case(7, "sundaresan", "match", F(1.14, 1.48)),
    Case(7, "strejc", "exact", N(1.14, 4), N(0.5, 5), errata="#26"),
    Case(7, "smith", "n/a", None, errata="#13", reason="(0.5551)"),
    # Tab. 8: 2/((0.2s+1)(0.4s+1)(0.6s+1)(0.8s+1)(s+1))
    Case(8, "latzel", "match", N(0.758, 4)),
    Case(8, "viteckova2", "match", N(1.08, 2, 0.913)),
    # sum 2.136 and r = 0.42 (ERRATA #9, #27)
    Case(8, "harriott", "exact", L(0.563, 1.57, 0.913), L(1.2383, 0.8973, 0.9122),
         errata="#9, #27"),
    Case(8, "viteckova1", "match", F(1.69, 1.51)),
    Case(8, "sundaresan", "match", F(1.5, 1.64)),
    Case(8, "strejc", "exact", N(1.5, 4), N(0.752, 4), errata="#26"),
    Case(8, "smith", "n/a", None, errata="#13", reason="(0.5551)"),
]


def canonical(model: ProcessModel) -> tuple[str, dict[str, float]]:
    """Structure and parameters with two lags ordered (T1 the larger) and delay explicit."""
    p = {k: float(v) for k, v in model.params.items()}
    p.setdefault("delay", 0.0)
    if model.structure == "two_lags":
        p["T1"], p["T2"] = max(p["T1"], p["T2"]), min(p["T1"], p["T2"])
    return model.structure, p


def assert_params(got: ProcessModel, want: ProcessModel, rel: float, abs_small: float,
                  small: float = 0.5) -> None:
    """Each parameter within ``rel`` relative, or ``abs_small`` absolute for a time below
    ``small`` seconds; the order n exactly."""
    gs, gp = canonical(got)
    ws, wp = canonical(want)
    assert gs == ws, f"structure {gs} != {ws}"
    for k, w in wp.items():
        g = gp[k]
        if k == "n":
            assert g == w, f"n = {g}, expected {w}"
        elif k == "K" or abs(w) >= small:
            assert g == pytest.approx(w, rel=rel), f"{k} = {g:.5g}, expected {w:.5g}"
        else:
            assert abs(g - w) <= abs_small, f"{k} = {g:.5g}, expected {w:.5g}"


def model_ise(system: int, model: ProcessModel) -> float:
    return ise(ISE_GRID, true_step(system, ISE_GRID), model.unit_step(ISE_GRID))


@pytest.mark.parametrize("case", CASES, ids=str)
def test_jakoubek_tables(case: Case) -> None:
    fit = identify(event(case.system), case.method)
    if case.kind == "n/a":
        assert fit.status == "not_applicable", fit
        assert case.reason in fit.reason
        return
    assert fit.status == "ok", fit.reason
    if case.kind == "match":
        assert_params(fit.model, case.paper, rel=0.02, abs_small=0.01)
        return
    # a chart-reading error or a wrong row in the paper: the exact value instead
    assert_params(fit.model, case.exact, rel=0.005, abs_small=0.002)
    ours, printed = model_ise(case.system, fit.model), model_ise(case.system, case.paper)
    if case.ise_check == "lower":
        assert ours < printed, f"ISE {ours:.3g} not below the printed model's {printed:.3g}"
    else:  # the refined Harriott (ERRATA #10) is below; the default stays comparable
        refined = harriott(event(case.system), exact_x73=True).model
        assert model_ise(case.system, refined) < printed
        assert ours < 2.0 * printed


def test_system_5_response_is_exact() -> None:
    """The partial-fraction response of eq. (30) against scipy's polynomial simulation."""
    from scipy import signal

    den = np.poly1d([1.0])
    for ti in LAGS5:
        den = den * np.poly1d([ti, 1.0])
    t = np.linspace(0.0, 20.0, 2001)
    _, y = signal.step(signal.lti([2.0], den.coeffs), T=t)
    np.testing.assert_allclose(true_step(5, t), y, atol=1e-9)
    for system in SYSTEMS:  # the builder's lag chains are the systems
        np.testing.assert_allclose(true_step(system, t),
                                   lag_chain_step(JAKOUBEK_LAGS[system], t, K=2.0), atol=1e-9)


def test_paper_j_is_the_ise_of_its_printed_model() -> None:
    """ERRATA [S2] 23: the printed J equals our ISE (20 s, unit input step) of the printed
    model whenever J >~ 1e-3, except the rows ERRATA flags (#24, #26)."""
    rows = [(4, L(0.2, 0.304), 2.61e-2), (4, N(0.318, 2), 8.49e-2),
            (5, F(0.784, 0.276), 8.46e-3), (5, F(1.01), 5.50e-2),
            (6, F(1.1), 7.26e-3), (6, N(0.639, 2), 8.42e-2),
            (7, N(0.838, 2, 0.906), 7.83e-3), (7, L(0.437, 1.22, 0.906), 1.48e-2),
            (8, F(1.69, 1.51), 3.85e-2), (8, L(0.563, 1.57, 0.913), 1.28e-2)]
    for table, model, j in rows:
        assert model_ise(table - 3, model) == pytest.approx(j, rel=0.05)
    # the flagged rows are far off: V1 Tab. 6 (#24), Strejc Tab. 7 (#26)
    assert model_ise(3, F(0.1, 0.105)) > 1000 * 4.38e-4
    assert model_ise(4, N(1.14, 4)) > 5 * 0.299
