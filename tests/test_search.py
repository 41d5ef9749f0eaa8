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


def test_noise_like_reads_white_noise_as_noise_and_a_pattern_or_colour_as_not():
    """White noise's mean square is half its differences' (ratio 1); an AR(1) residual
    (phi 0.9: ratio 1 / (1 - phi) = 10) and white noise plus a slow misfit of its own size
    (ratio about 2) are not."""
    from pipeline.refine.search import noise_like
    k = np.arange(600)
    for seed in range(20):
        e = np.random.default_rng(seed).normal(0.0, 1.0, k.size)
        ar = np.zeros_like(e)
        for i in range(1, e.size):
            ar[i] = 0.9 * ar[i - 1] + e[i]
        assert noise_like(e)
        assert not noise_like(ar)
        assert not noise_like(e + np.sqrt(2.0) * np.sin(np.pi * k / k.size))
    assert not noise_like(np.array([1.0, -1.0]))  # too short to tell


def _two_valleys(noise: np.ndarray):
    """A residual of white ``noise`` plus a slow pattern whose size is the distance in
    log T from the deep basin at 2 s (no pattern there), and 0.3 at a shallow one at 50 s."""
    k = np.arange(noise.size)
    pattern = np.sin(np.pi * k / k.size)

    def fun(z):
        lt = float(z[0])
        a = min(0.5 * abs(lt - np.log(2.0)), 0.3 + 0.5 * abs(lt - np.log(50.0)))
        return noise + a * pattern
    return fun


def test_a_start_that_ends_in_the_noise_is_the_answer_and_a_misfit_tries_the_others(
        monkeypatch):
    """The best-ranked start converged where the residual is the noise: no other start is
    piloted, and the optimum is the full search's (every start piloted: BASIN_RATIO 0);
    where it converged in a shallow basin (a slow misfit left), the others are tried and
    the deep basin found."""
    import pipeline.refine.search as search
    noise = np.random.default_rng(1).normal(0.0, 0.05, 400)
    fun = _two_valleys(noise)
    quick = multistart(fun, SPACE, [{"T": 2.5}, {"T": 40.0}, {"T": 0.3}], 2, 300)
    assert quick.runs == 1 and quick.params["T"] == pytest.approx(2.0, rel=0.05)
    monkeypatch.setattr(search, "BASIN_RATIO", 0.0)
    full = multistart(fun, SPACE, [{"T": 2.5}, {"T": 40.0}, {"T": 0.3}], 2, 300)
    assert full.runs == 2 and full.params["T"] == pytest.approx(quick.params["T"], rel=1e-3)
    monkeypatch.undo()
    shallow = multistart(fun, SPACE, [{"T": 40.0}, {"T": 8.0}], 2, 300)
    assert shallow.runs == 2 and shallow.params["T"] == pytest.approx(2.0, rel=0.05)
