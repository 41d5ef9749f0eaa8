"""Work shared by the methods of one event (issue 14 item 5) and methods on an event whose
input did not change (issue 13 item 14): not applicable, never an internal error."""

from __future__ import annotations

import gc
from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import savgol_filter

import pipeline.signal as signal
from pipeline.errors import NotApplicable
from pipeline.events import EventData
from pipeline.methods import REGISTRY, identify, prepared
from pipeline.methods.base import input_change, normalised
from pipeline.models import ProcessModel
from pipeline.segmentation.detect import segment
from pipeline.synth import step_record


def _event(noise: float = 0.045, dt: float = 0.5) -> EventData:
    truth = ProcessModel("two_lags", {"K": 1.5, "T1": 10.0, "T2": 3.0, "delay": 1.0})
    rec = step_record(truth, u0=2.0, changes=[(30.0, 5.0)], t_end=160.0, dt=dt, y0=7.0,
                      noise=noise, seed=3)
    return EventData.from_event(rec, segment(rec)[0])


GRAPHICAL_STEP = [m.id for m in REGISTRY.values() if m.kind == "graphical"
                  and m.accepts("step")]


@pytest.mark.parametrize("kind", ["step", "impulse"])
def test_every_method_on_an_unchanged_input_is_not_applicable(kind: str) -> None:
    """A "step" whose input did not move (u_ss == u0, the zero-height step a short pulse
    inside a step became) and a pulse without area: every registered method says not
    applicable with its reason; before, 9 graphical step methods failed with
    ZeroDivisionError and the refinements came back ok."""
    ev = replace(_event(), kind=kind, u_ss=_event().u0, area=0.0)
    for mid in REGISTRY:
        fit = identify(ev, mid)
        assert fit.status == "not_applicable", (mid, fit.status, fit.reason)
        assert fit.reason and "internal error" not in fit.reason, (mid, fit.reason)
        assert fit.model is None


def test_an_input_change_within_the_input_noise_is_none() -> None:
    """|du| within 3 noise standard deviations of the input is no step (the input's noise
    read from its first differences, as segmentation reads it)."""
    ev = _event()
    rng = np.random.default_rng(0)
    u = ev.u + rng.normal(0.0, 0.1, ev.u.size)
    noisy = replace(ev, u=u, u_ss=ev.u0 + 0.2)
    with pytest.raises(NotApplicable, match="within the input's noise"):
        input_change(noisy)
    for mid in GRAPHICAL_STEP:
        assert identify(noisy, mid).status == "not_applicable", mid
    assert input_change(replace(ev, u=u)) == ev.du  # a real step through the same noise


def test_the_event_is_smoothed_once_for_all_methods(monkeypatch) -> None:
    """All graphical step methods on one noisy event smooth its response once (they did
    it about 24 times)."""
    ev = _event()
    calls = []
    real = signal.savgol
    monkeypatch.setattr(signal, "savgol", lambda *a, **k: calls.append(a[1]) or real(*a, **k))
    fits = [identify(ev, m) for m in GRAPHICAL_STEP]
    assert sum(f.ok for f in fits) >= 8
    assert len(calls) == 1


def test_shared_readings_give_the_results_of_separate_ones() -> None:
    """Each method on its own copy of the event (nothing shared) and all methods on one
    event (every reading shared, in catalogue order and reversed): the same fits, to the
    bit, noisy and noise-free."""
    for ev in (_event(), _event(noise=0.0)):
        alone = {m: identify(replace(ev), m) for m in GRAPHICAL_STEP}
        shared = {m: identify(ev, m) for m in GRAPHICAL_STEP}
        back = {m: identify(replace(ev), m) for m in reversed(GRAPHICAL_STEP)}
        for m in GRAPHICAL_STEP:
            for other in (shared[m], back[m]):
                assert (other.status, other.reason, other.diagnostics) == \
                    (alone[m].status, alone[m].reason, alone[m].diagnostics), m
                assert (other.model is None) == (alone[m].model is None)
                if other.model is not None:
                    assert other.model.params == alone[m].model.params, m


def test_per_event_readings_are_kept_with_the_event_and_dropped_after_it() -> None:
    ev = _event()
    r = normalised(ev)
    assert normalised(ev) is r and r.hs is r.hs
    assert not r.h.flags.writeable and not r.hs.flags.writeable
    tau, h, sigma = r  # unpacks as before
    assert h is r.h and sigma == ev.noise / abs(ev.dy)
    flat = replace(ev, y=np.full(ev.y.size, ev.y0), y_ss=ev.y0)
    for _ in range(2):  # the reason is kept and raised again
        with pytest.raises(NotApplicable, match="did not change measurably"):
            normalised(flat)
    n = len(prepared._CACHE)
    del ev, r, flat
    gc.collect()
    assert len(prepared._CACHE) <= n - 2


@pytest.mark.parametrize("n, window", [(600, 11), (12_000, 241), (60_000, 1201)])
def test_long_smoothing_window_by_fft_matches_savgol_filter(n: int, window: int) -> None:
    """The overlap-add path of pipeline.signal (from SAVGOL_FFT_TAPS taps on) equals
    scipy's savgol_filter to rounding, edges (their own polynomial fits) included; below
    it, to the bit."""
    rng = np.random.default_rng(n)
    h = 1.0 - np.exp(-np.arange(n) / (n / 6)) + 0.01 * rng.normal(size=n)
    for deriv, delta in ((0, 1.0), (1, 0.01)):
        ref = savgol_filter(h, window, 2, deriv=deriv, delta=delta)
        got = signal.savgol(h, window, deriv, delta)
        if window < signal.SAVGOL_FFT_TAPS:
            assert np.array_equal(got, ref)
        else:
            assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref))
