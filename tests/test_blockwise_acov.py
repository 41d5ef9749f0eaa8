"""The blockwise autocovariance of the variance factor (issue 30 item 5): blocks no
longer than the series and FFTs no longer than a block's lags need, the same sums as the
direct products (known truth: ``sum_t x_t x_(t+j)`` computed term by term)."""

import numpy as np
import pytest

from pipeline.uncertainty import _blockwise_acov, variance_factor


@pytest.mark.parametrize(("n", "k"), [(8_200, 1023), (20_000, 1023), (70_000, 1023),
                                      (140_000, 16383), (9_000, 1)])
def test_blockwise_sums_equal_the_direct_products(n, k):
    rng = np.random.default_rng(n + k)
    x = rng.normal(size=n)
    x -= x.mean()
    direct = np.array([x[: n - j] @ x[j:] for j in range(k + 1)])
    got = _blockwise_acov(x, k)
    assert got.shape == (k + 1,)
    assert np.max(np.abs(got - direct)) <= 1e-9 * direct[0]


def test_ar1_factor_on_a_long_residual_is_the_ar1_value():
    # AR(1) phi 0.9: f = (1 + phi) / (1 - phi) = 19; 40,000 samples take the blockwise
    # path (the initial positive sequence runs past the 32 direct lags)
    rng = np.random.default_rng(3)
    n, phi = 40_000, 0.9
    w = rng.normal(size=n)
    e = np.empty(n)
    e[0] = w[0]
    for i in range(1, n):
        e[i] = phi * e[i - 1] + w[i]
    assert variance_factor(e) == pytest.approx(19.0, rel=0.15)
