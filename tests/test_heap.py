"""The C heap's freed pages given back between stages (:mod:`pipeline.heap`)."""

import sys

import numpy as np
import pytest

from pipeline import heap


def _rss() -> int:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * 4096


@pytest.mark.skipif(heap._malloc_trim() is None, reason="no glibc malloc_trim here")
def test_freed_window_sized_arrays_are_given_back():
    """Window-sized arrays (below glibc's mapping threshold, so on the heap) freed in a
    checkerboard, as an analysis frees its windows: the holes stay resident until
    release(), which returns most of them (at least half of the 50 MB)."""
    keep, drop = [], []
    for k in range(1000):
        (keep if k % 2 else drop).append(np.ones(12_000))  # 96 kB each
    drop.clear()
    before = _rss()
    heap.release()
    assert before - _rss() >= 25e6
    assert len(keep) == 500


def test_release_is_harmless_without_glibc(monkeypatch):
    monkeypatch.setattr(sys, "platform", "darwin")
    heap._malloc_trim.cache_clear()
    try:
        assert heap._malloc_trim() is None
        heap.release()  # a no-op, not an error
    finally:
        heap._malloc_trim.cache_clear()
