"""One conformance test every registered method passes (STYLE.md 10), picked up from
``pipeline.methods.REGISTRY`` (methods registered later are covered automatically): on a
fixed set of events it returns ok or not_applicable with a reason, never raises, never
mutates its input, returns a structure from its registered ``structures``; plus a
property-based sweep over random plants (hypothesis)."""

from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pipeline.errors import NotApplicable
from pipeline.events import EventData
from pipeline.methods import REGISTRY, identify
from pipeline.methods.registry import ANY_EVENT
from pipeline.models import ProcessModel
from pipeline.record import make_record
from pipeline.synth import response, staircase
from tests.builders import flat, fo, impulse, nl, so, step, tl, truncated

OP = dict(u0=1.0, u1=3.0, t0=5.0, y0=-2.0, dt=0.01, after=35.0)
PULSE = dict(u0=2.0, height=4.0, width=0.05, t_on=2.0, y0=0.5, dt=0.005, t_end=30.0)
PLANTS = {
    "first": fo(2.0),
    "fopdt": fo(2.0, 0.7),
    "underdamped": so(0.31, 5.05, K=0.25),
    "two_lags": tl(2.0, 0.4),
    "five_lags": nl(0.5, 5),
    "integrator_lag": ProcessModel("integrator_lag", {"K": 0.5, "T": 1.0, "delay": 0.3}),
    "inverse": ProcessModel("zero_two_lags", {"K": 2.0, "Tz": -1.5, "T1": 3.0, "T2": 0.8}),
    "lead_lag": ProcessModel("lead_lag", {"K": 2.0, "Tz": 4.0, "T": 1.0}),
}

#: The fixed event set: steps up and down, a negative gain, impulses of both signs,
#: noise-free, white and coloured noise, no output change, short and cut windows.
EVENTS: dict[str, Callable[[], EventData]] = {
    **{f"step-{k}": (lambda m=m: step(m, **OP)) for k, m in PLANTS.items()},
    **{f"step-down-{k}": (lambda m=m: step(m, **dict(OP, u0=3.0, u1=1.0)))
       for k, m in PLANTS.items()},
    "step-negative-gain": lambda: step(tl(2.0, 0.4, K=-3.0), **OP),
    "step-white-noise": lambda: step(PLANTS["two_lags"], **OP, noise_rel=0.02),
    "step-coloured-noise": lambda: step(PLANTS["first"], **OP, noise_rel=0.01, phi=0.8),
    "step-underdamped-noisy": lambda: step(PLANTS["underdamped"], **OP, noise_rel=0.02),
    "step-drowned": lambda: step(PLANTS["fopdt"], **OP, noise_rel=0.5, seed=3),
    "step-short-window": lambda: step(PLANTS["first"], **dict(OP, after=0.8)),
    "step-no-change": lambda: flat("step"),
    "step-no-change-noisy": lambda: flat("step", noise_sd=0.01),
    "impulse-first": lambda: impulse(PLANTS["first"], **PULSE),
    "impulse-underdamped": lambda: impulse(PLANTS["underdamped"], **PULSE),
    "impulse-negative": lambda: impulse(PLANTS["first"], **dict(PULSE, height=-4.0)),
    "impulse-noisy": lambda: impulse(PLANTS["underdamped"], **PULSE, noise_rel=0.02),
    "impulse-coloured-noise": lambda: impulse(PLANTS["first"], **PULSE, noise_rel=0.02,
                                              phi=0.8),
    "impulse-no-response": lambda: flat("impulse"),
    "impulse-cut-after-peak": lambda: truncated(impulse(PLANTS["underdamped"], **PULSE),
                                                450),
    "impulse-no-area": lambda: replace(impulse(PLANTS["first"], **PULSE), area=0.0),
    "impulse-integrator": lambda: impulse(PLANTS["integrator_lag"], **PULSE),
    "step-integrator-noisy": lambda: step(PLANTS["integrator_lag"], **OP, noise_rel=0.01),
}


@pytest.mark.parametrize("event", list(EVENTS))
@pytest.mark.parametrize("method", list(REGISTRY))
def test_every_method_on_every_event(method: str, event: str) -> None:
    """ok or not_applicable with a reason, never an exception (also called directly,
    outside :func:`identify`), never a mutated input, a registered structure, finite
    parameters, a non-negative delay whose clipping is recorded."""
    ev = EVENTS[event]()
    arrays = [ev.t.copy(), ev.u.copy(), ev.y.copy()]
    info = REGISTRY[method]
    if info.accepts(ev.kind):
        try:
            info.func(ev)
        except NotApplicable as exc:
            assert exc.reason
    fit = identify(ev, method)
    assert fit.status in ("ok", "not_applicable"), f"{fit.status}: {fit.reason}"
    if fit.ok:
        assert fit.model.structure in info.structures
        assert all(np.isfinite(v) for v in fit.model.params.values())
        assert fit.model.K != 0 and fit.model.delay >= 0
        assert np.all(np.isfinite(fit.model.unit_step(np.linspace(0, 10, 101))))
        d = fit.diagnostics
        if "delay_computed" in d:
            assert d["delay_clipped"] == (d["delay_computed"] < 0)
            assert fit.model.delay == (0.0 if d["delay_clipped"] else d["delay_computed"])
    else:
        assert fit.reason and len(fit.reason) > 10
    if event.startswith(("step-no-change", "impulse-no-response", "impulse-no-area")):
        assert fit.status == "not_applicable"
    for before, after in zip(arrays, (ev.t, ev.u, ev.y), strict=True):
        assert np.array_equal(before, after)


def test_the_event_set_covers_every_registered_kind() -> None:
    """A method registered later (least squares, integrating processes) is run on events
    of its own kind: every kind the registry knows has events here."""
    kinds = {EVENTS[e]().kind for e in EVENTS}
    assert {m.event for m in REGISTRY.values()} - {ANY_EVENT} <= kinds


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
    from pipeline.segmentation.detect import segment

    events = segment(rec)
    assert len(events) == 1
    ev = EventData.from_event(rec, events[0])
    for method in REGISTRY:
        if REGISTRY[method].kind == "refinement" and seed % 4:
            continue  # the refinements (tens of ms each) on a quarter of the plants
        fit = identify(ev, method)
        assert fit.status in ("ok", "not_applicable"), (method, fit.reason)
