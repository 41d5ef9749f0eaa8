"""Least-squares refinement with known truth: exact regressors, recovery of every structure,
the generated ``lsq_<structure>`` methods, the initial state (rest, carried, estimated),
several events with one model, and what results.json carries."""

import math

import numpy as np
import pytest

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.config import config_from_dict
from pipeline.methods import REGISTRY, identify, method_ids, select_methods
from pipeline.methods.lsq import refinement_id, register_refinements
from pipeline.models import _BOUNDS_DELAY, STRUCTURES, ProcessModel, Structure
from pipeline.record import make_record
from pipeline.refine.refinement import RefineOptions, refine
from pipeline.results import RunResult, parse_results, results_json
from pipeline.run import analysis_options
from pipeline.segmentation.detect import event_data
from pipeline.simulation import forced_response, free_basis
from pipeline.simulation.engine import simulate
from pipeline.synth import response, staircase, step_record

FOPDT = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 2.0})
PLANTS = {
    "first_order": ProcessModel("first_order", {"K": 2.0, "T": 3.0, "delay": 0.37}),
    "second_order": ProcessModel("second_order", {"K": -0.8, "zeta": 0.3, "wn": 1.1,
                                                  "delay": 0.23}),
    "two_lags": ProcessModel("two_lags", {"K": 1.5, "T1": 4.0, "T2": 1.2, "delay": 0.61}),
    "n_lags": ProcessModel("n_lags", {"K": 3.0, "T": 0.8, "n": 4, "delay": 0.45}),
}


def _superposed(model: ProcessModel, t, u, u0):
    """Exact reference: a held input is a sum of steps, each a closed-form step response."""
    du = np.diff(u - u0, prepend=0.0)
    y = np.zeros_like(t)
    for k in np.flatnonzero(du):
        y += du[k] * model.unit_step(t - t[k])
    return y


@pytest.mark.parametrize("name", list(PLANTS))
def test_forced_response_is_exact_with_fractional_delays(name):
    model = PLANTS[name]
    t = np.arange(600) * 0.1
    u = staircase(t, 1.0, [(2.03, 2.5), (21.0, 0.5), (40.0, 1.7)])
    u = u + 0.05 * np.sin(0.7 * t)  # every sample a change: the pulse response, not steps
    ref = _superposed(model, t, u, 1.0)
    got = forced_response(model.structure, dict(model.params), t, u - 1.0) * model.K
    assert np.max(np.abs(got - ref)) < 1e-10
    assert np.max(np.abs(simulate(model, t, u, 1.0, 3.0) - 3.0 - ref)) < 1e-10


def test_free_basis_spans_the_response_to_an_earlier_input():
    """Two lags (no dead time) started in an unknown state: its free response lies in the
    span of the basis (to 1e-9), whatever input put it there."""
    model = PLANTS["two_lags"]
    p = {**model.params, "delay": 0.0}
    m0 = ProcessModel("two_lags", p)
    t = np.arange(-300, 400) * 0.05
    u = staircase(t, 0.0, [(-12.0, 1.0), (-3.0, -0.4), (-0.6, 0.7)])
    y = simulate(m0, t, u, 0.0, 0.0)
    after = t >= 0
    free = y[after] - simulate(m0, t[after], np.full(after.sum(), 0.7), 0.7, 0.0) - 0.7 * 1.5
    b = np.column_stack([np.ones(after.sum()), free_basis("two_lags", p, t[after], 20.0)])
    c, *_ = np.linalg.lstsq(b, free, rcond=None)
    assert np.max(np.abs(b @ c - free)) < 1e-9


@pytest.mark.parametrize("name", list(PLANTS))
def test_noise_free_refinement_recovers_each_structure(name):
    truth = PLANTS[name]
    t = np.arange(0, 40, 0.02)
    u = staircase(t, 1.0, [(3.0, 3.0)])
    ev = event_data(t, u, response(truth, t, u, 1.0, -4.0))
    fit = identify(ev, refinement_id(name))
    assert fit.ok, fit.reason
    for k, v in truth.params.items():
        assert fit.model.params[k] == pytest.approx(v, rel=2e-3, abs=2e-3), k
    assert set(fit.ci95) == set(truth.params)
    assert fit.refinement.state_text == "rest"
    if name == "n_lags":
        assert float(fit.model.params["n"]).is_integer()  # chosen among integers


def test_one_generated_method_per_structure_everywhere_methods_are_listed():
    for name in STRUCTURES:
        mid = refinement_id(name)
        assert REGISTRY[mid].kind == "refinement" and REGISTRY[mid].structures == (name,)
        assert mid in method_ids("step") and mid in select_methods("all", "step")
        assert "Ljung" in REGISTRY[mid].citation


def test_a_new_structure_entry_gets_its_refinement(monkeypatch):
    """An integrator (step response t, growing without bound) added to the table: its
    ``lsq_`` method appears, and it recovers gain, dead time and the input balance point."""
    spec = Structure("test_integrator", ("K", "delay"), "K e^{-delay s}/s",
                     step=lambda p, t: np.asarray(t, float),
                     num_den=lambda p: ([p["K"]], [1.0, 0.0]), text=lambda p, d: "K/s",
                     time_scale=lambda p: 0.0, order_class=lambda p: "first",
                     bounds=dict(_BOUNDS_DELAY), integrating=True)
    monkeypatch.setitem(STRUCTURES, "test_integrator", spec)
    try:
        register_refinements()
        assert "lsq_test_integrator" in method_ids("step")
        truth = ProcessModel("test_integrator", {"K": 0.5, "delay": 1.5})
        rec = step_record(truth, u0=2.0, changes=[(20.0, 3.0), (40.0, 2.0)], t_end=60.0,
                          dt=0.25, y0=7.0, noise=0.05, seed=1)
        res = analyse(rec, AnalysisOptions(methods=("lsq_test_integrator",)))
        (fit,) = res.fits
        assert fit.model.params["K"] == pytest.approx(0.5, rel=0.02)
        assert fit.model.params["delay"] == pytest.approx(1.5, abs=0.1)
        assert fit.refinement.u0 == pytest.approx(2.0, abs=0.01)
        lo, hi = fit.ci95["K"]
        assert lo < 0.5 < hi
        assert fit.metrics["mse_validation"] < 1.3 * 0.05**2  # the drift is not noise
    finally:
        REGISTRY.pop("lsq_test_integrator", None)


def _fopdt(changes, t_end, seed):
    return step_record(FOPDT, u0=2.0, changes=changes, t_end=t_end, dt=0.25, y0=7.0,
                       noise=0.06, seed=seed)


def _graphical_gains(res) -> list[float]:
    return [f.model.K for f in res.fits if f.ok and REGISTRY[f.method].kind == "graphical"]


def _k_t_errors(fit) -> list[float]:
    return [fit.model.K / 2 - 1, fit.model.params["T"] / 10 - 1]


def test_short_window_from_rest():
    """A step whose window is only 1.5 T long: the graphical gain (last tenth of the
    window) is 20 % or more low, the least-squares gain within 5 % (median of 20 seeds)."""
    k_lsq, k_graph = [], []
    for seed in range(20):
        res = analyse(_fopdt([(20.0, 5.0)], 35.0, seed))
        assert not res.events[0].settled
        fit = res.fit("lsq_first_order", 0)
        assert fit.refinement.state_text == "rest"
        k_lsq.append(fit.model.K / 2.0 - 1)
        k_graph.append(max(_graphical_gains(res)) / 2.0 - 1)
    assert np.median(np.abs(k_lsq)) < 0.05
    assert max(k_graph) < -0.2


def test_step_on_a_decaying_tail_carries_the_state():
    """A step 2 T after the previous one, window 2 T: the state is carried from the first
    event's rest (the measured input since drives it); K and T within 5 % (median)."""
    errs = []
    for seed in range(20):
        res = analyse(_fopdt([(20.0, 5.0), (40.0, 3.0)], 60.0, seed),
                      AnalysisOptions(events=(1,)))
        fit = res.fit("lsq_first_order", 1)
        assert fit.refinement.state_text == "carried from event 0"
        errs.append(_k_t_errors(fit))
        # a reading from rest on a tail: refused (the output still moves the other way) or
        # far off, never close to the truth
        gains = _graphical_gains(res)
        assert not gains or max(gains) < 0.7 * 2.0
        assert not res.fit("inverse_response", 1).ok  # the tail's momentum is not a zero
    assert np.all(np.median(np.abs(errs), axis=0) < 0.05)


def test_state_estimated_when_the_record_starts_moving():
    """The log starts while the output still settles from an unlogged step: the baseline
    drifts, so the initial state is estimated; its free response shows before the step."""
    errs = []
    for seed in range(10):
        full = _fopdt([(5.0, 3.5), (45.0, 5.0)], 145.0, seed)
        keep = full.t >= 20.0
        rec = make_record(full.t[keep] - 20.0, full.u[keep], full.y[keep], name="moving",
                          source="<moving>")
        res = analyse(rec, AnalysisOptions(methods=("lsq_first_order",)))
        (fit,) = res.fits
        assert fit.refinement.state_text == "estimated"
        errs.append(_k_t_errors(fit))
    assert np.all(np.median(np.abs(errs), axis=0) < 0.05)


def _staircase_record(seed, gains=None, noise=0.03):
    """Five steps of a first-order plant with dead time, each window 4-6 T; ``gains``:
    a different gain per step (a plant whose gain changes with the operating point)."""
    model = ProcessModel("first_order", {"K": 2.0, "T": 5.0, "delay": 1.0})
    t = np.arange(0, 300, 0.25)
    changes = [(20.0, 3.0), (50.0, 1.5), (80.0, 2.5), (110.0, 1.0), (140.0, 2.0)]
    u = staircase(t, 2.0, changes)
    if gains is None:
        y = simulate(model, t, u, 2.0, 5.0)
    else:
        y = np.full(t.size, 5.0)
        prev = 2.0
        for (tc, level), g in zip(changes, gains, strict=True):
            y += g * (level - prev) * model.unit_step(t - tc) / model.K
            prev = level
    y = y + np.random.default_rng(seed).normal(0.0, noise, t.size)
    return make_record(t[t < 170], u[t < 170], y[t < 170], name="stairs", source="<stairs>")


def test_one_model_over_all_events_with_cross_validation():
    rec = _staircase_record(3)
    res = analyse(rec, AnalysisOptions(events="all", methods=("first_order",
                                                              "lsq_first_order")))
    joint = next(f for f in res.fits if f.method == "lsq_first_order" and f.events)
    assert joint.events == (0, 1, 2, 3, 4) and joint.event == 0
    assert joint.model.params == pytest.approx({"K": 2.0, "T": 5.0, "delay": 1.0}, rel=0.02)
    assert [f.events for f in joint.refinement.folds] == [(0,), (1,), (2,), (3,), (4,)]
    assert joint.metrics["mse_cross_validation"] == pytest.approx(0.03**2, rel=0.25)
    per_event = [f for f in res.fits if f.method == "lsq_first_order" and not f.events]
    assert all("mse_cross_validation" in f.metrics for f in per_event)
    assert res.recommended is not None and res.recommended.model.structure == "first_order"


def test_a_joint_fit_does_not_hide_a_gain_that_changes():
    """Gains 2.0 -> 1.2 across the steps: per-event refinements find each gain, the joint
    model has one gain and no per-event parameters, and its held-out error shows the
    misfit (many times the noise variance)."""
    gains = [2.0, 1.8, 1.6, 1.4, 1.2]
    rec = _staircase_record(4, gains=gains)
    res = analyse(rec, AnalysisOptions(events="all", methods=("lsq_first_order",)))
    joint = next(f for f in res.fits if f.events)
    assert set(joint.model.params) == {"K", "T", "delay"}
    per_event = sorted((f for f in res.fits if not f.events), key=lambda f: f.event)
    for f, g in zip(per_event, gains, strict=True):
        assert f.model.K == pytest.approx(g, rel=0.03)
    assert joint.metrics["mse_cross_validation"] > 20 * 0.03**2


def test_results_json_carries_intervals_events_and_the_recommendation():
    rec = _staircase_record(5)
    res = analyse(rec, AnalysisOptions(events=(0, 2), methods=("viteckova1",
                                                               "lsq_first_order")))
    doc = parse_results(results_json(RunResult([res]).to_doc()))
    (r,) = doc.records
    lsq = [f for f in r.fits if f.method == "lsq_first_order"]
    assert sorted(f.events for f in lsq) == [[], [], [0, 2]]
    for f in lsq:
        assert set(f.ci95) == {"K", "T", "delay"}
        lo, hi = f.ci95["K"]
        assert lo < f.params["K"] < hi
        assert f.diagnostics["initial_state"] in ("rest", "carried from event 0")
    assert r.recommended.method == res.recommendation.method
    assert r.recommended.structure == "first_order" and r.recommended.reason
    assert set(r.recommended.ci95) == {"K", "T", "delay"}
    assert all(f.metrics.aic is not None for f in r.fits if f.status == "ok" and not f.events)


def test_config_identification_options():
    cfg = config_from_dict({"data": {"path": "x.csv", "input": "u", "output": "y"},
                            "identification": {"events": "all", "starts": 2,
                                               "bootstrap": 40}})
    opt = analysis_options(cfg)
    assert opt.events == "all" and opt.refine == RefineOptions(n_starts=2, bootstrap=40)
    from pipeline.errors import UserError

    with pytest.raises(UserError, match="identification.starts"):
        config_from_dict({"data": {"path": "x.csv", "input": "u", "output": "y"},
                          "identification": {"starts": 0}})


def test_bootstrap_intervals_are_an_option():
    t = np.arange(0, 100, 0.5)
    u = staircase(t, 2.0, [(20.0, 5.0)])
    y = response(FOPDT, t, u, 2.0, 7.0, 0.06, seed=2)
    ref = refine(t, u, y, "first_order", u_ref=2.0, starts=[{"T": 8.0, "delay": 1.0}],
                 options=RefineOptions(bootstrap=60, seed=1))
    assert ref.diagnostics["interval_method"] == "block bootstrap (60 refits)"
    for k, v in FOPDT.params.items():
        lo, hi = ref.ci95[k]
        assert lo < ref.model.params[k] < hi and hi - lo < 0.2 * v, k
    assert math.isfinite(ref.mse) and ref.mse == pytest.approx(0.06**2, rel=0.25)


def test_folds_are_single_events_up_to_the_cap_then_interleaved():
    from pipeline.refine.joint import MAX_FOLDS, folds_of
    assert folds_of([0, 2, 5]) == [[0], [2], [5]]
    assert folds_of(range(MAX_FOLDS)) == [[i] for i in range(MAX_FOLDS)]
    many = folds_of(range(23))
    assert len(many) == MAX_FOLDS and many[0] == [0, 10, 20] and many[9] == [9, 19]
    assert sorted(j for f in many for j in f) == list(range(23))  # each held out once


def test_cross_validation_beyond_the_fold_cap_holds_every_event_out_once():
    """Twelve steps of one plant: ten folds (not twelve refits), every event held out in
    exactly one of them, and the pooled held-out error is the noise's variance."""
    model = ProcessModel("first_order", {"K": 2.0, "T": 5.0, "delay": 1.0})
    t = np.arange(0, 26 * 30.0 + 30, 0.25)
    levels = [3.0, 1.5, 2.5, 1.0, 2.0, 3.5, 1.2, 2.8, 1.8, 3.2, 1.4, 2.6]
    u = staircase(t, 2.0, [(20.0 + 30.0 * k, v) for k, v in enumerate(levels)])
    noise = 0.03
    y = simulate(model, t, u, 2.0, 5.0) + np.random.default_rng(4).normal(0, noise, t.size)
    keep = t < 20.0 + 30.0 * len(levels)
    rec = make_record(t[keep], u[keep], y[keep], name="stairs12", source="<stairs12>")
    res = analyse(rec, AnalysisOptions(events="all", methods=("lsq_first_order",)))
    assert len(res.events) == 12
    joint = next(f for f in res.fits if f.events)
    folds = joint.refinement.folds
    assert len(folds) == 10 and sorted(j for f in folds for j in f.events) == list(range(12))
    assert joint.model.params == pytest.approx({"K": 2.0, "T": 5.0, "delay": 1.0}, rel=0.02)
    assert joint.metrics["mse_cross_validation"] == pytest.approx(noise**2, rel=0.25)
    assert res.recommended is not None


def test_one_event_models_are_scored_on_at_most_ten_other_events():
    from pipeline.refine.joint import held_out_events
    assert held_out_events([0, 1, 2, 3], 2) == [0, 1, 3]
    many = held_out_events(range(200), 7)
    assert len(many) == 10 and 7 not in many and many[0] == 0
    assert np.all(np.diff(many) > 0)  # spread over the record, in order
    sets = [set(held_out_events(range(200), j)) for j in range(200)]
    # one spread set for every model: any two share at least nine events
    assert min(len(a & b) for a in sets for b in sets) >= 9
    assert all(j not in s for j, s in enumerate(sets))


@pytest.mark.parametrize("structure,truth,state", [
    # a long window: the coarse-to-fine search; two lags started in the other order, found
    # in the canonical one (T1 >= T2)
    ("two_lags", {"K": 1.5, "T1": 9.0, "T2": 3.0, "delay": 1.0}, "rest"),
    # an integrating structure with its state estimated: the input balance point is fitted
    ("integrator_lag", {"K": 0.2, "T": 4.0, "delay": 0.5}, "estimated"),
])
def test_refine_model_is_refine_without_the_intervals(structure, truth, state):
    """A cross-validation fold's refit (:func:`pipeline.refine.refinement.refine_model`) gives the
    model and balance point :func:`refine` gives, to the bit, on noisy data."""
    from pipeline.refine.refinement import refine_model
    t = np.arange(0, 300, 0.1)
    u = staircase(t, 1.0, [(20.0, 2.0), (150.0, 1.5)])
    model = ProcessModel(structure, truth)
    y = simulate(model, t, u, 1.0, 4.0) + np.random.default_rng(5).normal(0, 0.02, t.size)
    mask = t >= 10.0
    starts = [{k: 1.3 * truth[{"T1": "T2", "T2": "T1"}.get(k, k)] for k in truth if k != "K"}]
    ref = refine(t, u, y, structure, u_ref=1.0, starts=starts, mask=mask, initial_state=state)
    m, u0 = refine_model(t, u, y, structure, u_ref=1.0, starts=starts, mask=mask,
                         initial_state=state)
    assert t.size > 2 * RefineOptions().max_rows  # the coarse pass ran
    assert m == ref.model and u0 == ref.u0
    assert (u0 != 1.0) == (state == "estimated")  # the balance point was fitted
    assert m.params == pytest.approx(truth, rel=0.1)


def test_a_fit_over_many_short_events_keeps_rows_within_each_event():
    """1,200 steps of a first-order plant, 200 samples each: a joint fit over them with a
    one-event fit's 600 criterion rows (and its decimated search: one sample per two
    events) averaged each transient away and came out as K -1.1, T 2,011 s, dead time
    2,674 s. With :data:`pipeline.refine.joint.ROWS_PER_EVENT` rows per event it finds the
    plant."""
    from pipeline.events import EventData
    from pipeline.refine.event import event_states
    from pipeline.refine.joint import ROWS_PER_EVENT, span_fit, span_options
    from pipeline.segmentation.detect import segment
    n, n_events, dt = 240_000, 1200, 0.1
    rng = np.random.default_rng(0)
    w = n // (n_events + 1)
    levels = 5.0 + (-1.0) ** np.arange(n_events) * rng.uniform(0.6, 1.4, n_events)
    t = np.arange(n) * dt
    u = np.concatenate([np.full(w, 5.0), np.repeat(levels, w), np.full(n - w * (n_events + 1),
                                                                       levels[-1])])
    truth = ProcessModel("first_order", {"K": 2.0, "T": w * dt / 8, "delay": 0.3})
    y = simulate(truth, t, u, 5.0, 20.0) + rng.normal(0.0, 0.02, n)
    rec = make_record(t, u, y, name="many", source="<many>")
    events = segment(rec)
    assert len(events) == n_events
    ident = list(range(n_events))
    assert span_options(None, ident).max_rows == ROWS_PER_EVENT * n_events
    start = identify(EventData.from_event(rec, events[0]), "first_order")
    fit = span_fit(rec, events, ident, "lsq_first_order", "first_order", models=[start.model],
                   states=event_states(rec, events))
    assert fit.ok and fit.events == tuple(ident)
    assert fit.model.params == pytest.approx(truth.params, rel=0.02)
