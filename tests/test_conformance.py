"""One conformance test every registered method passes (STYLE.md 10): on any event it
returns ok or not_applicable with a reason, never raises, never mutates its input; plus a
property-based sweep over random plants (hypothesis)."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pipeline.events import EventData
from pipeline.methods import REGISTRY, identify
from pipeline.models import ProcessModel
from pipeline.record import make_record
from pipeline.segment import event_data
from pipeline.synth import pulse, response, staircase


def _step(model, *, u0=1.0, u1=3.0, t0=5.0, y0=-2.0, dt=0.01, t_end=40.0, noise=0.0, seed=0):
    t = np.arange(int(round(t_end / dt)) + 1) * dt
    u = staircase(t, u0, [(t0, u1)])
    y = response(model, t, u, u0, y0, noise * abs(model.K * (u1 - u0)), seed)
    return event_data(t, u, y)


def _impulse(model, *, u0=2.0, height=4.0, width=0.05, t0=2.0, y0=0.5, dt=0.005,
             t_end=30.0, noise=0.0):
    t = np.arange(int(round(t_end / dt)) + 1) * dt
    u = pulse(t, u0, t0, width, height)
    y = response(model, t, u, u0, y0, noise * model.K * height * width, 1)
    return event_data(t, u, y)


PLANTS = {
    "first": ProcessModel("first_order", {"K": 2.0, "T": 2.0}),
    "fopdt": ProcessModel("first_order", {"K": 2.0, "T": 2.0, "delay": 0.7}),
    "underdamped": ProcessModel("second_order", {"K": 0.25, "zeta": 0.31, "wn": 5.05}),
    "two_lags": ProcessModel("two_lags", {"K": 2.0, "T1": 2.0, "T2": 0.4}),
    "five_lags": ProcessModel("n_lags", {"K": 2.0, "T": 0.5, "n": 5}),
}
EVENTS = {
    **{f"step-{k}": (lambda m=m: _step(m)) for k, m in PLANTS.items()},
    **{f"negative-step-{k}": (lambda m=m: _step(m, u0=3.0, u1=1.0)) for k, m in PLANTS.items()},
    "noisy-step-two-lags": lambda: _step(PLANTS["two_lags"], noise=0.01),
    "impulse-first": lambda: _impulse(PLANTS["first"]),
    "impulse-underdamped": lambda: _impulse(PLANTS["underdamped"]),
    "no-change": lambda: event_data(
        np.arange(1000) * 0.01, staircase(np.arange(1000) * 0.01, 0, [(2.0, 1.0)]),
        np.zeros(1000), y_ss=0.0),
}


@pytest.mark.parametrize("event", list(EVENTS))
@pytest.mark.parametrize("method", list(REGISTRY))
def test_every_method_on_every_event(method, event):
    ev = EVENTS[event]()
    arrays = [ev.t.copy(), ev.u.copy(), ev.y.copy()]
    fit = identify(ev, method)
    assert fit.status in ("ok", "not_applicable"), f"{fit.status}: {fit.reason}"
    if fit.ok:
        assert all(np.isfinite(v) for v in fit.model.params.values())
        assert fit.model.K != 0
    else:
        assert fit.reason and len(fit.reason) > 10
    for before, after in zip(arrays, (ev.t, ev.u, ev.y), strict=True):
        assert np.array_equal(before, after)


@st.composite
def plants(draw):
    kind = draw(st.sampled_from(["first_order", "second_order", "two_lags", "n_lags"]))
    K = draw(st.floats(0.05, 50)) * draw(st.sampled_from([1, -1]))
    delay = draw(st.sampled_from([0.0, draw(st.floats(0.0, 2.0))]))
    if kind == "first_order":
        p = {"T": draw(st.floats(0.2, 5.0))}
    elif kind == "second_order":
        p = {"zeta": draw(st.floats(0.1, 2.0)), "wn": draw(st.floats(0.5, 8.0))}
    elif kind == "two_lags":
        p = {"T1": draw(st.floats(0.2, 4.0)), "T2": draw(st.floats(0.01, 2.0))}
    else:
        p = {"T": draw(st.floats(0.1, 1.5)), "n": draw(st.integers(2, 8))}
    return ProcessModel(kind, {"K": K, "delay": delay, **p})


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(model=plants(), u0=st.floats(-10, 10), du=st.floats(0.2, 5.0),
       sign=st.sampled_from([1, -1]), t0=st.floats(0.5, 20.0), y0=st.floats(-100, 100),
       noise=st.sampled_from([0.0, 0.003, 0.01, 0.05]), seed=st.integers(0, 2**16))
def test_no_method_crashes_on_random_plants(model, u0, du, sign, t0, y0, noise, seed):
    slow = max(model.lags() or [1.0 / model.params.get("wn", 1.0)]) * 8 + model.delay
    span = max(slow * float(model.params.get("n", 1)), 10.0)
    dt = span / 3000
    t = np.arange(3001 + int(t0 / dt)) * dt
    u1 = u0 + sign * du
    u = staircase(t, u0, [(t0, u1)])
    y = response(model, t, u, u0, y0, noise * abs(model.K * du), seed)
    rec = make_record(t, u, y, name="h", source="<hypothesis>")
    from pipeline.segment import segment

    events = segment(rec)
    assert len(events) == 1
    ev = EventData.from_event(rec, events[0])
    for method in REGISTRY:
        fit = identify(ev, method)
        assert fit.status in ("ok", "not_applicable"), (method, fit.reason)
