"""Segmentation, linear in samples and events (issue 14 item 2), gives exactly what the
sample-by-sample scan gave; no event without an input change (issue 13 item 14); extreme
magnitudes segment without overflow (issue 13 item 15).

The reference loops below are the scan as it was before (one sample at a time, each
look-ahead over the whole rest of the record): :mod:`pipeline.segmentation.edges` must
return the same indices on every input.
"""

import warnings

import numpy as np
import pytest
from scipy.stats import trim_mean

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.errors import UserError
from pipeline.models import ProcessModel
from pipeline.record import Record, make_record
from pipeline.segmentation import edges
from pipeline.segmentation.detect import (
    SegmentOptions,
    _trim_mean,
    event_data,
    input_threshold,
    segment,
)
from pipeline.synth import response
from pipeline.synth.closed_loop import pi_loop_record

# -- the reference: the scan sample by sample ---------------------------------------------

def _ref_first_stable(u, start, level, thr, m):
    near = np.abs(u[start:] - level) <= thr
    for i in np.flatnonzero(near):
        if near[i : i + m].all():
            return start + int(i)
    return None


def _ref_departure(u, start, level, thr):
    off = np.flatnonzero(np.abs(u[start:] - level) > thr)
    return start + int(off[0]) if off.size else u.size


def _ref_plateau_start(u, k, thr, m, sigma_u=0.0, m_flat=10):
    flat = max(3.0 * sigma_u * np.sqrt(2.0 / m_flat), thr / 20)
    for j in range(k, u.size):
        w = u[j : j + m]
        if not np.all(np.abs(w - np.median(w)) <= thr / 2):
            continue
        v = u[j : j + 2 * m_flat]
        half = v.size // 2
        if half < m or abs(float(np.mean(v[:half]) - np.mean(v[half:]))) <= flat:
            return j
    return k


def _ref_walk_back(u, k, level, sigma_u):
    tol = max(3 * sigma_u, 1e-9 * max(1.0, abs(level)))
    while k > 0 and abs(u[k - 1] - level) > tol and abs(u[k - 1] - level) < abs(u[k] - level):
        k -= 1
    return k


def _ref_scan(t, u, level, thr, sigma_u, m=3, pf=0.1):
    n, raws, k = u.size, [], 0
    while k < n:
        if abs(u[k] - level) <= thr:
            k += 1
            continue
        back = _ref_first_stable(u, k + 1, level, thr, m)
        if back is not None:
            nxt = _ref_departure(u, back, level, thr)
            t_next = t[nxt] if nxt < n else t[-1] + (t[-1] - t[-2])
            if t[back] - t[k] < pf * (t_next - t[k]):
                if back - k <= 2 and np.max(np.abs(u[k:back] - level)) < 2 * thr:
                    k = back
                    continue
                raws.append(edges.Raw("impulse", _ref_walk_back(u, k, level, sigma_u), back,
                                      level))
                k = back
                continue
        j = _ref_plateau_start(u, k, thr, m, sigma_u)
        raws.append(edges.Raw("step", _ref_walk_back(u, k, level, sigma_u), j, level))
        level = float(np.median(u[j : j + m]))
        k = j
    return raws


def _inputs(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Random inputs of every shape the scan meets: staircases with noise, slow ramps,
    pulses of 1-30 samples, returns to an old level, spikes, quantised levels."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(50, 6000))
    t = np.cumsum(rng.uniform(0.5, 1.5, n)) if seed % 5 == 0 else np.arange(n) * 0.1
    u = np.zeros(n)
    i = int(rng.integers(0, 40))
    levels = rng.choice([0.0, 1.0, 2.0, 2.05, 3.0], size=20) if seed % 3 == 0 else None
    while i < n:
        kind = rng.choice(["step", "pulse", "ramp", "spike"])
        if kind == "step":
            u[i:] = levels[int(rng.integers(0, 20))] if levels is not None else rng.normal(0, 2)
        elif kind == "pulse":
            u[i : i + int(rng.integers(1, 30))] += rng.normal(0, 2)
        elif kind == "ramp":
            m = int(rng.integers(5, 400))
            u[i : i + m] += np.linspace(0, rng.normal(0, 2), m)[: u[i : i + m].size]
            u[i + m :] = u[min(n - 1, i + m - 1)]
        else:
            u[i] += rng.normal(0, 3)
        i += int(rng.integers(1, 800))
    u = u + rng.normal(0, rng.choice([0.0, 0.003, 0.05]), n)
    if seed % 7 == 0:
        u = np.round(u, 1)
    return t, u


@pytest.mark.parametrize("seed", range(60))
def test_scan_equals_the_sample_by_sample_scan(seed):
    t, u = _inputs(seed)
    thr, sigma_u = input_threshold(u, None, SegmentOptions())
    level = float(u[0])
    ref = _ref_scan(t, u, level, thr, sigma_u)
    assert edges.scan(t, u, level, thr, sigma_u, stable=3, pulse_fraction=0.1) == ref


@pytest.mark.parametrize("seed", range(40))
def test_searches_equal_their_loops(seed):
    t, u = _inputs(seed)
    rng = np.random.default_rng(1000 + seed)
    thr, sigma_u = input_threshold(u, None, SegmentOptions())
    for m in (1, 3, 5):
        ext = edges._Extremes(u, m)
        for _ in range(20):
            start = int(rng.integers(0, u.size))
            level = float(u[int(rng.integers(0, u.size))])
            assert ext.first_stable(start, level, thr, u.size) == _ref_first_stable(
                u, start, level, thr, m)
            assert edges.departure(u, start, level, thr) == _ref_departure(u, start, level, thr)
            assert edges.plateau_start(u, start, thr, m, sigma_u) == _ref_plateau_start(
                u, start, thr, m, sigma_u)
            assert edges.walk_back(u, start, level, sigma_u) == _ref_walk_back(
                u, start, level, sigma_u)


def test_trim_mean_is_scipys_to_the_bit():
    rng = np.random.default_rng(5)
    for _ in range(2000):
        a = rng.normal(size=int(rng.integers(1, 400))) * 10 ** rng.uniform(-3, 3)
        a = np.round(a, 1) if rng.random() < 0.3 else a
        assert _trim_mean(a, 0.1) == float(trim_mean(a, 0.1))


# -- issue 13 item 14: no zero-height event ------------------------------------------------

FO = ProcessModel("first_order", {"K": 2.0, "T": 5.0})


def _pulse_in_step():
    """u: 0 -> 1 at t = 20, a 1.5 s pulse to 2 at t = 60, back to 1, then 0 at t = 72:
    the pulse is too long for the gap after it to be a pulse by its share of the time to
    the next change, and its plateau is the level it left."""
    t = np.arange(0, 200, 0.5)
    u = np.where(t >= 20, 1.0, 0.0)
    u[(t >= 60) & (t < 61.5)] = 2.0
    u[t >= 72] = 0.0
    y = response(FO, t, u, 0.0, 0.0, noise=0.01, seed=1)
    return make_record(t, u, y, name="pulse", source="<pulse in a step>")


def test_pulse_inside_a_step_is_a_pulse_not_a_zero_height_step():
    rec = _pulse_in_step()
    thr, _ = input_threshold(rec.u, None, SegmentOptions())
    evs = segment(rec)
    assert [(e.kind, e.t0) for e in evs] == [("step", 20.0), ("impulse", 60.0), ("step", 72.0)]
    assert all(abs(e.u_ss - e.u0) > thr for e in evs if e.kind == "step")
    assert evs[1].area == pytest.approx(1.5)  # 1.5 s at 1 above the level
    res = analyse(rec, AnalysisOptions(methods=("lsq_first_order", "first_order")))
    fits = [f for f in res.fits if f.event == 0 and f.ok]
    assert fits and all(f.model.params["K"] == pytest.approx(2.0, rel=0.03) for f in fits)
    assert all(f.model.params["T"] == pytest.approx(5.0, rel=0.08) for f in fits)
    assert not [f for f in res.fits if f.status == "failed"]


def test_closed_loop_inputs_give_no_step_without_a_change():
    """A PI controller's output wanders back near its level after a kick: the scan made
    steps of a few percent of the threshold there (e.g. -0.06 against 3.7)."""
    for s in range(30):
        rec = (pi_loop_record(noise=0.2 + 0.01 * (s % 10), seed=100 + s, K=1.5 + 0.02 * s)
               if s < 15 else pi_loop_record(noise=0.3, seed=s, K=-2.0))
        thr, _ = input_threshold(rec.u, None, SegmentOptions())
        for e in segment(rec):
            if e.kind == "step":
                assert abs(e.u_ss - e.u0) > 0.5 * thr
            else:
                assert abs(e.area) > 0


# -- issue 13 item 15: extreme magnitudes --------------------------------------------------

def _arrays(t, u, y) -> Record:
    """A record of the arrays as they are: segmentation is a pure function of a Record,
    whatever a loader would accept (make_record may refuse such magnitudes)."""
    return Record(t=np.asarray(t, float), u=np.asarray(u, float), y=np.asarray(y, float),
                  name="s", source="<arrays>")


def _plain():
    t = np.arange(0, 200, 0.5)
    u = np.where((t >= 20) & (t < 110), 1.0, 0.0)
    return t, u, response(FO, t, u, 0.0, 0.0, noise=0.01, seed=1)


@pytest.mark.parametrize("et, eu, ey", [(0, 0, 1000), (0, 1020, 0), (0, 0, 500), (900, 0, 0),
                                        (-1000, 0, 0), (0, -1000, -1000), (0, 1000, 1000)])
def test_extreme_magnitudes_segment_exactly_as_scaled(et, eu, ey):
    """Scaled by powers of two, the events are those of the plain record, scaled (the
    record is segmented at a moderate magnitude, which need not be the plain one's: equal
    to rounding); nothing overflows on the way (warnings are errors here)."""
    t, u, y = _plain()
    base = segment(make_record(t, u, y, name="s", source="<plain>"))
    rec = _arrays(np.ldexp(t, et), np.ldexp(u, eu), np.ldexp(y, ey))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = segment(rec)
    assert len(got) == len(base) == 2
    for b, g in zip(base, got, strict=True):
        assert (g.kind, g.i_start, g.i_end, g.settled) == (b.kind, b.i_start, b.i_end, b.settled)
        for name, e in (("t0", et), ("u0", eu), ("u_ss", eu), ("y0", ey), ("y_ss", ey),
                        ("noise", ey), ("area", eu + et), ("slope", ey - et)):
            assert getattr(g, name) == pytest.approx(np.ldexp(getattr(b, name), e), rel=1e-9,
                                                     abs=np.ldexp(1e-12, e)), name


def test_values_near_the_largest_float_never_raise():
    t, u, y = _plain()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for uu, yy in ((u * 1.7e308, y), (u * -1.7e308 + 1e308, y * 1e307), (u, y * 1e300)):
            evs = segment(_arrays(t, uu, yy))
            assert [e.t0 for e in evs] == [20.0, 110.0]
            assert all(np.isfinite([e.u0, e.u_ss, e.y0, e.y_ss, e.noise]).all() for e in evs)
        thr, sig = input_threshold(np.array([-1.7e308, 1.7e308] * 10), None, SegmentOptions())
        assert np.isfinite(thr) and np.isfinite(sig)
        try:  # numpy arrays in, one EventData out; or a refusal in one line, never a crash
            data = event_data(t, u * 1e300, y * 1e300)
        except UserError as exc:
            assert "<arrays>" in exc.message
        else:
            assert data.u_ss == 1e300 and data.dy == pytest.approx(2e300, rel=0.01)
