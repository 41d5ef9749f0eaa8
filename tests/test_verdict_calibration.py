"""Verdicts and the recommendation against known truth (issue 27), over fixed seeds.

Every "must flag" has its "must stay ok" twin: clean, well-posed records under white,
AR(1) and 1/f noise are "ok" and right; records that are not (a short window, a gain that
changes between steps, a drifting baseline, a record no model can describe) are flagged.
The full Monte Carlo is ``benchmarks/verdict_calibration.py`` (its figures in the issue's
note); this is a subset that runs in the suite. ``-n0 -s`` prints the rates.
"""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.grading.recommendation import undetermined
from pipeline.models import ProcessModel
from pipeline.record import make_record
from pipeline.synth import response, staircase, step_record
from pipeline.synth.montecarlo import PLANTS, Condition, mc_record, noise, score

#: The subset of the well-posed sets: plants of every family but the integrating one.
CLEAN_PLANTS = ("fopdt_delay0.05", "fopdt_delay2", "two_lags", "underdamped_0.6", "lags_3",
                "lead_lag", "inverse_response")
#: Windows of 3 T (each next step from a moving output), noise as the issue's sets have it.
CLEAN_CONDITIONS = (Condition("white", 0.02, 3.0), Condition("ar1", 0.01, 3.0),
                    Condition("pink", 0.01, 3.0))
#: The share of clean records each noise colour's recommended model is "ok" on at least.
#: Measured on this subset: 100 %, 89 % and 96 % (before issue 27: 54 %, 32 %, 43 %; before
#: the held-out misfit allowed for the parameters' spread: 100 %, 82 %, 93 %); the issue's
#: goal is 95 %, met for white and 1/f noise, not yet for AR(1) (phi 0.9).
OK_AT_LEAST = {"white": 0.95, "ar1": 0.85, "pink": 0.9}
SEEDS = 4

#: model selection only (the tuning of the recommended model is tested in test_tuning*)
ONLY_MODELS = AnalysisOptions(tuning=None)


@pytest.fixture(scope="module")
def clean_rows() -> list[dict]:
    rows = []
    for name in CLEAN_PLANTS:
        for cond in CLEAN_CONDITIONS:
            for seed in range(SEEDS):
                res = analyse(mc_record(PLANTS[name], cond, seed), ONLY_MODELS)
                fit = res.recommended
                s = score(fit.model, PLANTS[name], cond)
                rows.append({"plant": name, "kind": cond.kind, "verdict": fit.verdict,
                             "right": s.right, "structure": s.structure,
                             "flags": [f.code for f in fit.flags if f.severity != "info"]})
    return rows


def _rate(rows, key) -> float:
    return sum(1 for r in rows if key(r)) / len(rows)


def test_clean_records_are_ok_right_and_of_the_true_structure(clean_rows):
    """84 clean records (7 plants; white 2 %, AR(1) and 1/f 1 %; windows of 3 T): the
    recommended model is "ok" (:data:`OK_AT_LEAST`) and right (its step response within
    3 % of the truth), and rarely "ok" when it is not right."""
    ok = _rate(clean_rows, lambda r: r["verdict"] == "ok")
    right = _rate(clean_rows, lambda r: r["right"])
    structure = _rate(clean_rows, lambda r: r["structure"])
    wrong_ok = _rate(clean_rows, lambda r: r["verdict"] == "ok" and not r["right"])
    print(f"\nclean: ok {ok:.1%}, right {right:.1%}, true structure {structure:.1%}, "
          f"wrong and ok {wrong_ok:.1%}",
          [(r["plant"], r["kind"], r["flags"]) for r in clean_rows if r["verdict"] != "ok"])
    for kind, least in OK_AT_LEAST.items():
        part = [r for r in clean_rows if r["kind"] == kind]
        assert _rate(part, lambda r: r["verdict"] == "ok") >= least, kind
    assert ok >= 0.88 and right >= 0.9 and structure >= 0.85 and wrong_ok <= 0.05


def test_one_step_records_give_no_undetermined_model_and_the_gain():
    """One step, nothing held out (the choice by AIC): never a recommended model with an
    undetermined parameter, and its gain within 3 % in at least 95 % of 20 seeds, for a
    first-order plant and a two-lag plant."""
    for truth in (ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 1.0}),
                  ProcessModel("two_lags", {"K": 1.5, "T1": 10.0, "T2": 3.0, "delay": 1.0})):
        gains, bad = [], []
        for seed in range(20):
            rec = step_record(truth, u0=2.0, changes=[(40.0, 5.0)], t_end=100.0, dt=0.2,
                              y0=7.0, noise=0.03 * truth.K, seed=seed)
            fit = analyse(rec, ONLY_MODELS).recommended
            gains.append(abs(fit.model.K / truth.K - 1) <= 0.03)
            if undetermined(fit):
                bad.append((seed, fit.method))
        assert not bad, bad
        assert np.mean(gains) >= 0.95, truth.structure


def test_one_verdict_per_model_whichever_events_identify():
    """A model's verdict reads its held-out error, from validation events or from
    cross-validation: a one-event refinement gets the same verdict with event 0
    identifying as with every event identifying (the stay-ok twin on a linear plant, the
    must-flag one on a plant whose gain moves 30 % between its steps)."""
    plant = PLANTS["fopdt_delay0.05"]
    linear = mc_record(plant, Condition("white", 0.01, 4.0), 3)
    t, u = linear.t, linear.u
    gain = np.where(u > 3.5, 1.3, 1.0)  # the gain at the high levels 30 % up
    y = response(plant.model, t, u, 2.0, 7.0) - 7.0
    y = 7.0 + y * np.interp(t, t, gain) + noise("white", t.size, 0.06, np.random.default_rng(3))
    moving = make_record(t, u, y, name="moving gain", source="<moving gain>")
    for rec, flagged in ((linear, False), (moving, True)):
        verdicts = []
        for events in ((0,), "all"):
            fit = analyse(rec, AnalysisOptions(tuning=None, events=events)).fit(
                "lsq_first_order", 0, ())
            verdicts.append((fit.verdict, "validation_misfit" in {f.code for f in fit.flags}))
        assert verdicts[0] == verdicts[1], (rec.name, verdicts)
        assert verdicts[0][1] == flagged, (rec.name, verdicts)


def test_a_slow_noise_baseline_is_no_drift_a_real_drift_is():
    """1/f noise wanders over a baseline as a drift would: no ``baseline_not_steady`` on
    ten such baselines (the error bar knows the noise's colour), while a slow warm-up
    still creeping by 8 % of the step over the baseline, under the same noise, is."""
    truth = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 1.0})
    t = np.arange(0.0, 160.0, 0.2)
    u = staircase(t, 2.0, [(60.0, 5.0)])
    flagged = []
    for seed in range(10):
        base = response(truth, t, u, 2.0, 7.0) + noise("pink", t.size, 0.03,
                                                      np.random.default_rng(seed))
        for drift in (0.0, 1.7):  # 1.7 (e^-1 - e^-2.5) = 0.49, 8 % of the step's 6
            y = base + drift * (1.0 - np.exp(-(t + 40.0) / 40.0))
            res = analyse(make_record(t, u, y, name="b", source="<b>"),
                          AnalysisOptions(tuning=None, methods=("first_order",)))
            codes = {f.code for f in res.fit("first_order", 0).flags}
            flagged.append((drift > 0, "baseline_not_steady" in codes))
    assert not any(f for d, f in flagged if not d), flagged
    assert sum(f for d, f in flagged if d) >= 9, flagged


def test_a_mostly_settled_window_is_information_a_short_one_a_warning():
    """A refinement that has reached 80-95 % of its final value by the end of its window
    says so as information (the gain is mostly seen); at 1.5 T (78 %) it is a warning."""
    truth = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 0.0})
    for window, severity in ((22.0, "info"), (15.0, "warning")):
        rec = step_record(truth, u0=2.0, changes=[(30.0, 5.0)], t_end=30.0 + window, dt=0.1,
                          y0=7.0, noise=0.02, seed=4)
        fit = analyse(rec, AnalysisOptions(tuning=None, methods=("lsq_first_order",))).fit(
            "lsq_first_order", 0)
        flag = next(f for f in fit.flags if f.code == "unsettled")
        assert flag.severity == severity, (window, flag.message)
    assert fit.verdict == "warning"


def test_no_usable_model_is_said_not_recommended():
    """A record every model misses badly (an output that jumps at random, unrelated to
    the input) gets no recommended model and a ``no_usable_model`` flag that says why;
    its clean twin gets its model."""
    t = np.arange(0.0, 300.0, 0.5)
    u = staircase(t, 1.0, [(50.0, 3.0), (150.0, 1.5), (220.0, 2.5)])
    rng = np.random.default_rng(2)
    y = 5.0 + np.repeat(rng.normal(0.0, 2.0, 12), t.size // 12 + 1)[: t.size]
    y += rng.normal(0.0, 0.02, t.size)
    res = analyse(make_record(t, u, y, name="junk", source="<junk>"), ONLY_MODELS)
    assert res.recommended is None
    (flag,) = [f for f in res.flags if f.code == "no_usable_model"]
    assert flag.severity == "unreliable" and "unreliable -" in flag.message
    clean = mc_record(PLANTS["two_lags"], Condition("white", 0.01, 4.0), 0)
    assert analyse(clean, ONLY_MODELS).recommended is not None


def test_a_self_regulating_plant_is_never_given_an_integrator():
    """Windows of one T (each step long before the output settles): a self-regulating plant
    is never recommended an integrating model, and no wrong model is "ok" (before issue
    27 the underdamped plant got an integrator in 9 of 10 seeds); a heater (first order,
    T 150 s, stepped up and down every 200 s) gets a self-regulating model in at least 95 %
    of 20 seeds; the integrating twin (an integrator with lag, every window a ramp) keeps
    its integrator."""
    given = []
    for name in ("underdamped_0.6", "two_lags", "fopdt_delay0.05"):
        for seed in range(5):
            cond = Condition("white", 0.005, 1.0)
            fit = analyse(mc_record(PLANTS[name], cond, seed), ONLY_MODELS).recommended
            if fit is not None:
                given.append((name, fit.model.integrating, fit.verdict == "ok"
                              and not score(fit.model, PLANTS[name], cond).right))
    assert not [g for g in given if g[1] or g[2]], given
    heater = ProcessModel("first_order", {"K": 0.6, "T": 150.0, "delay": 8.0})
    changes = [(100.0 + 200.0 * k, lv) for k, lv in enumerate((80.0, 20.0, 70.0, 10.0))]
    regulating = []
    for seed in range(20):
        rec = step_record(heater, u0=0.0, changes=changes, t_end=900.0, dt=1.0, y0=21.0,
                          noise=0.15, seed=seed)
        fit = analyse(rec, ONLY_MODELS).recommended
        regulating.append(fit is not None and not fit.model.integrating)
    assert np.mean(regulating) >= 0.95, regulating
    ramps = mc_record(PLANTS["integrator_lag"], Condition("white", 0.01, 4.0), 1)
    assert analyse(ramps, ONLY_MODELS).recommended.model.integrating


def test_a_record_that_starts_mid_transient_says_to_declare_the_initial_input():
    """The input already at its new level at the first row: the output's transient is
    seen before the first visible event, and the record says to declare initial_input; the
    same record with it declared, one that starts at rest, and an integrator already
    ramping steadily at the start (a motor that turns) say nothing; an input constant over
    the whole record is no event, and the error says its level and the remedy."""
    truth = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 1.0})
    t = np.arange(0.0, 200.0, 0.2)
    u = staircase(t, 5.0, [(80.0, 3.0), (140.0, 4.5)])
    y = response(truth, t, u, 2.0, 7.0, noise=0.02, seed=1)  # 2 -> 5 just before t = 0
    hidden = make_record(t, u, y, name="hidden", source="<hidden>")
    declared = make_record(t, u, y, name="declared", source="<declared>", initial_input=2.0)
    at_rest = mc_record(PLANTS["fopdt_delay0.05"], Condition("pink", 0.01, 3.0), 0)
    motor = ProcessModel("integrator_lag", {"K": 0.05, "T": 5.0, "delay": 1.0})
    tm = np.arange(-100.0, 200.0, 0.2)  # ramping long before the record starts
    um = staircase(tm, 3.0, [(80.0, 1.0), (140.0, 3.5)])  # its balance point is 2
    ym = response(motor, tm, um, 2.0, 7.0, noise=0.01, seed=2)
    keep = tm >= 0
    turning = make_record(tm[keep], um[keep], ym[keep], name="turning", source="<turning>")
    found = {r.name: {f.code for f in analyse(r, ONLY_MODELS).flags}
             for r in (hidden, declared, at_rest, turning)}
    assert "starts_mid_transient" in found["hidden"], found
    assert not any("starts_mid_transient" in found[k] for k in
                   ("declared", at_rest.name, "turning")), found
    flat = make_record(t, np.full(t.size, 50.0), y, name="flat", source="<flat>")
    err = analyse(flat, ONLY_MODELS).error
    assert "constant at 50" in err and "initial_input" in err, err
