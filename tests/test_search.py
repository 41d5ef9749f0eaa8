"""The multistart search (:func:`pipeline.refine.search.multistart`): a run that ends with a time
constant at its upper bound (a hundred spans, far beyond the data) sends every other
candidate start through the search, and the lowest cost is kept."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.refine.search import FAR_BOUND, far_bound, multistart, search_space

#: A one-lag search over a 10 s span at 0.1 s: T from 1e-3 to 1000 s (log scale).
SPACE = search_space("first_order", ["T"], 0.1, 10.0)


def _two_basins(z: np.ndarray) -> np.ndarray:
    """A residual with a deep minimum at T = 2 s (cost 0.005) and a valley that falls
    slowly all the way to the upper bound (cost 0.031 there): a slow lag fitting a drift."""
    T = float(np.exp(z[0]))
    deep = 0.1 + 0.5 * np.log(T / 2.0) ** 2
    valley = 0.2 + 1.0 / (1.0 + T / 50.0)
    return np.array([min(deep, valley), 0.0])


def test_a_run_to_the_far_bound_tries_the_other_starts():
    # the two best-ranked starts (400 s and 200 s) both slide down the valley to 1000 s
    starts = [{"T": 200.0}, {"T": 400.0}, {"T": 30.0}, {"T": 0.5}]
    run = multistart(_two_basins, SPACE, starts, 2, 300)
    assert run.params["T"] == pytest.approx(2.0, rel=1e-3)
    assert run.cost == pytest.approx(0.005, rel=1e-3)
    assert run.runs == 4  # every distinct candidate was tried
    # with no other start to try, the bound is where the search ends
    alone = multistart(_two_basins, SPACE, starts[:2], 2, 300)
    assert alone.params["T"] == pytest.approx(1000.0, rel=1e-6)


def test_a_run_inside_the_bounds_tries_no_more_starts():
    starts = [{"T": 1.0}, {"T": 3.0}, {"T": 30.0}, {"T": 400.0}]
    run = multistart(_two_basins, SPACE, starts, 2, 300)
    assert run.params["T"] == pytest.approx(2.0, rel=1e-3)
    assert run.runs == 2


def test_far_bound_is_a_time_constant_at_its_upper_bound_only():
    lo, hi = SPACE.lo[0], SPACE.hi[0]
    assert far_bound(SPACE, np.array([hi - 0.5 * FAR_BOUND * (hi - lo)]))
    assert not far_bound(SPACE, np.array([hi - 2 * FAR_BOUND * (hi - lo)]))
    assert not far_bound(SPACE, np.array([lo]))
    damping = search_space("second_order", ["zeta", "wn"], 0.1, 10.0)
    # an overdamped second order (zeta at its bound) is a first-order response, no alarm
    assert not far_bound(damping, np.array([damping.hi[0], 0.0]))
    # a natural frequency at its lowest (a period a hundred spans long) is one
    assert far_bound(damping, np.array([0.0, damping.lo[1]]))


def test_no_start_limit_tries_every_distinct_start():
    starts = [{"T": 200.0}, {"T": 400.0}, {"T": 30.0}, {"T": 0.5}]
    run = multistart(_two_basins, SPACE, starts, 0, 300)
    assert run.runs == 4 and run.params["T"] == pytest.approx(2.0, rel=1e-3)


def test_kept_residuals_are_bounded_and_change_nothing(monkeypatch):
    """A search over a long residual (20,000 rows: a fit over many events) keeps at most
    MEMO_BYTES of residuals to reuse; with room for one alone it simulates a start again
    where it would have reused it, and ends at the same parameters and cost."""
    import pipeline.refine.search as search
    t = np.linspace(0.0, 10.0, 20_000)
    y = 1.0 - np.exp(-t / 2.0)
    calls = []

    def fun(z):
        calls.append(1)
        return y - (1.0 - np.exp(-t / float(np.exp(z[0]))))

    real = search.multistart

    def run(budget):
        calls.clear()
        monkeypatch.setattr(search, "MEMO_BYTES", budget)
        out = real(fun, SPACE, [{"T": 1.0}, {"T": 5.0}, {"T": 30.0}], 2, 300)
        return out, len(calls)

    roomy, n_roomy = run(1 << 40)
    tight, n_tight = run(1)
    assert tight.params == roomy.params and tight.cost == roomy.cost
    assert roomy.params["T"] == pytest.approx(2.0, rel=1e-6)
    assert n_tight > n_roomy  # the starts' residuals were simulated again
