"""The regression gate on the tuned controller, against known truth: Monte Carlo plants
logged again with fresh white, AR(1) and 1/f noise must not raise a tuning finding (the
settings move, within their spread over the model's intervals); the same plants with
twice the dead time must (SIMC's Kc = T/(K (tau_c + theta)) halves)."""

from __future__ import annotations

from dataclasses import replace

import pytest

import pipeline
from pipeline.analysis import AnalysisOptions
from pipeline.gate.baseline import Tolerances, compare
from pipeline.gate.tuning_findings import tuning_findings
from pipeline.models import ProcessModel
from pipeline.results import RunResult
from pipeline.synth.montecarlo import NOISE_KINDS, PLANTS, Condition, Plant, mc_record

#: plants whose recommended model is a refinement with intervals (FOPDT over a range of
#: delay/lag and a chain of six lags, which the rules reduce by the half rule)
NAMES = ("fopdt_delay0.05", "fopdt_delay0.5", "lags_6")
OPTIONS = AnalysisOptions(methods=("lsq_first_order", "lsq_two_lags", "lsq_n_lags"))


def _doc(plants: dict[str, Plant], seed: int):
    records = []
    for key, plant in plants.items():
        for kind in NOISE_KINDS:
            rec = replace(mc_record(plant, Condition(kind=kind), seed), name=f"{key} {kind}")
            records.append(pipeline.analyse(rec, OPTIONS))
    return RunResult(records).to_doc()


def _tuning(f):
    return f.kind in ("tuning_drift", "tuning_verdict")


@pytest.fixture(scope="module")
def nights():
    plants = {n: PLANTS[n] for n in NAMES}
    longer = {n: Plant(n, ProcessModel(p.model.structure, {
        **p.model.params, "delay": 2.0 * p.model.params["delay"]})) for n, p in plants.items()}
    return _doc(plants, 1), _doc(plants, 2), _doc(longer, 3)


def test_fresh_noise_moves_the_settings_but_raises_no_tuning_finding(nights):
    base, fresh, _ = nights
    moved = [abs(c.tuning.controller.Kc / b.tuning.controller.Kc - 1.0)
             for b, c in zip(base.records, fresh.records, strict=True)]
    assert max(moved) > 0.005  # the settings did move: the gate compares different numbers
    found = [f.message for f in compare(fresh, base).regressions if _tuning(f)]
    assert found == []


def test_a_longer_dead_time_is_a_tuning_drift_on_the_recommended_model(nights):
    base, _, longer = nights
    result = compare(longer, base)
    drift = [f for f in result.regressions if f.kind == "tuning_drift"]
    # Kc = T/(K 2 theta) halves and Ti = min(T, 8 theta) doubles where 8 theta < T: every
    # FOPDT record, all noise colours, has a drifted setting; the dead time of a fast
    # loop (0.5 s on 10 s) is a small change of the model (5 % of its time scale: no
    # param_drift) but not of its tuning. Except under 1/f noise: there the fast loop's
    # intervals, widened by the held-out residuals' noise (issue 27 item 8), make the
    # doubled 2.5-sample dead time a change within 1.4 times the two nights' spread
    # (Kc -1.51 against 2.37, Ti +2.56 against 3.23; before the widening, with intervals
    # that covered the gain in 73 % under 1/f noise, -1.83 against 1.49)
    expected = {f"{n} {k}" for n in NAMES[:2] for k in NOISE_KINDS} - {"fopdt_delay0.05 pink"}
    assert expected <= {f.record for f in drift}
    assert not [f for f in result.regressions if f.kind == "param_drift"
                and f.record.startswith("fopdt_delay0.05") and "(recommended" in f.message]
    for f in drift:
        rec = next(r for r in longer.records if r.name == f.record)
        assert (f.event, f.method) == (rec.recommended.event, rec.recommended.label)
        assert "(recommended model)" in f.message
        assert f.parameter != "Kc" or f.change == pytest.approx(-0.5, abs=0.15)


def test_verdict_worse_action_flip_kind_change_and_rule_change(nights):
    base, _, _ = nights
    b = base.records[0]
    tol = Tolerances()
    key = (b.recommended.event, b.recommended.label)

    def with_tuning(**kw):
        return b.model_copy(update={"tuning": b.tuning.model_copy(update=kw)})

    worse = tuning_findings(b.name, with_tuning(verdict="unstable_in_interval",
                                                reasons=["unstable on 3 % of sets"]),
                            b.model_copy(update={"tuning": b.tuning.model_copy(
                                update={"verdict": "robust"})}), key, tol)
    assert [f.kind for f in worse] == ["tuning_verdict"] and "3 %" in worse[0].message
    flipped = b.tuning.controller.model_copy(update={"Kc": -b.tuning.controller.Kc})
    assert [f.parameter for f in tuning_findings(
        b.name, with_tuning(controller=flipped), b, key, tol)] == ["action"]
    pid = b.tuning.controller.model_copy(update={"kind": "PID", "Kc": 9.0})
    kind = tuning_findings(b.name, with_tuning(controller=pid), b, key, tol)
    assert [(f.kind, f.parameter) for f in kind] == [("new", "kind")]  # information only
    assert tuning_findings(b.name, with_tuning(rule="amigo", controller=pid), b, key,
                           tol) == []
    gone = tuning_findings(b.name, with_tuning(status="not_applicable", reason="no gain"),
                           b, key, tol)
    assert [f.kind for f in gone] == ["tuning_verdict"] and "no gain" in gone[0].message
    # a tighter tolerance than the settings' spread still needs the spread to be exceeded
    kc = b.tuning.controller.Kc
    lo, hi = b.tuning.controller_ci95["Kc"]
    inside = b.tuning.controller.model_copy(update={"Kc": kc + 0.4 * (hi - lo)})
    assert tuning_findings(b.name, with_tuning(controller=inside), b, key,
                           Tolerances(param_tols={"Kc": 0.0})) == []
    # beyond SPREAD_FACTOR (1.4) times the combined half-widths, sqrt(2) (hi - lo)/2
    outside = b.tuning.controller.model_copy(update={"Kc": kc + 1.2 * (hi - lo)})
    assert [f.parameter for f in tuning_findings(
        b.name, with_tuning(controller=outside), b, key,
        Tolerances(param_tols={"Kc": 0.0}))] == ["Kc"]


def test_held_settings_are_compared_by_their_default(nights):
    """Settings held back from a fragile default follow the interval's width: when either
    night's were, the gate compares the rule's default settings (``replaced``) and their
    spread. The held Kc moving by half is no finding while the default did not move; the
    default moving beyond its spread is one, said as the default's."""
    from pipeline.schema import ReplacedDoc

    base, _, _ = nights
    b = base.records[0]
    key = (b.recommended.event, b.recommended.label)
    tol = Tolerances()
    own = b.tuning.controller
    held = own.model_copy(update={"Kc": 0.5 * own.Kc})

    def night(controller, default):
        rep = ReplacedDoc(tau_c=1.0, controller=default, verdict="fragile",
                          controller_ci95=dict(b.tuning.controller_ci95))
        return b.model_copy(update={"tuning": b.tuning.model_copy(
            update={"controller": controller, "replaced": rep, "controller_ci95": {}})})

    # tonight held (half the gain), last night the same default given as it was
    assert tuning_findings(b.name, night(held, own), b, key, tol) == []
    # both nights held, at different gains, from the same default
    assert tuning_findings(b.name, night(held, own), night(own, own), key, tol) == []
    # the default itself moved far beyond its spread: a finding, named as the default's
    lo, hi = b.tuning.controller_ci95["Kc"]
    moved = own.model_copy(update={"Kc": own.Kc + 3.0 * (hi - lo) + 0.5 * own.Kc})
    found = tuning_findings(b.name, night(held, moved), b, key, tol)
    assert [f.parameter for f in found] == ["Kc"]
    assert "the rule's default tuned Kc drifted" in found[0].message



def test_settings_from_another_recommended_structure_are_not_compared(nights):
    """gate_nights' case: a lead-lag recommended one night and a first-order model the
    next gave SIMC settings 25 % apart on the same plant; the change is information, the
    model's own findings say whether it moved. With the model drifted it is compared."""
    base, _, _ = nights
    b = base.records[0]
    key = (b.recommended.event, b.recommended.label)
    other = b.recommended.model_copy(update={"structure": "lead_lag"})
    moved = b.tuning.controller.model_copy(update={"Kc": 2.0 * b.tuning.controller.Kc})
    cur = b.model_copy(update={"recommended": other, "tuning": b.tuning.model_copy(
        update={"controller": moved})})
    found = tuning_findings(b.name, cur, b, key, Tolerances())
    assert [(f.kind, f.parameter) for f in found] == [("new", "structure")]
    assert [f.parameter for f in tuning_findings(b.name, cur, b, key, Tolerances(),
                                                 model_drifted=True)] == ["Kc"]
