"""Synthetic log folders: deterministic, known truth, corrupted files really bad."""

from __future__ import annotations

import numpy as np
import polars as pl
import pytest

from pipeline.errors import UserError
from pipeline.methods import identify
from pipeline.segmentation.detect import event_data
from pipeline.synth.logs import (
    CORRUPTIONS,
    log_record,
    night_drift,
    plan_logs,
    write_nights,
    write_synthetic_logs,
)


def test_same_seed_same_bytes(tmp_path):
    a = write_synthetic_logs(tmp_path / "a", 3, seed=7, corrupt=1)
    b = write_synthetic_logs(tmp_path / "b", 3, seed=7, corrupt=1)
    assert [p.name for p in a] == ["log_000.csv", "log_001.csv", "log_002.csv"]
    assert [p.read_bytes() for p in a] == [p.read_bytes() for p in b]
    c = write_synthetic_logs(tmp_path / "c", 3, seed=8)
    assert a[0].read_bytes() != c[0].read_bytes()


def test_fresh_noise_keeps_plant_and_input():
    base = plan_logs(4, seed=3)
    fresh = plan_logs(4, seed=3, noise_seed=99)
    assert [(p.K, p.T, p.changes, p.u0, p.y0) for p in base] == \
        [(p.K, p.T, p.changes, p.u0, p.y0) for p in fresh]
    ra, rb = log_record(base[0]), log_record(fresh[0])
    np.testing.assert_array_equal(ra.u, rb.u)
    assert not np.array_equal(ra.y, rb.y)
    # the noise has the requested size: about 1 % of the mean step (K * 10)
    resid = ra.y - rb.y  # difference of two independent noise draws
    assert np.std(resid) / np.sqrt(2) == pytest.approx(0.01 * 2.0 * 10, rel=0.1)


def test_plants_vary_mildly_and_drift_multiplies_gain():
    plans = plan_logs(50, seed=1)
    ks = np.array([p.K for p in plans])
    ts = np.array([p.T for p in plans])
    assert np.all(np.abs(ks / 2.0 - 1) <= 0.05) and np.all(np.abs(ts / 5.0 - 1) <= 0.05)
    assert ks.std() > 0.01 and all(p.delay == 0.5 for p in plans)
    drifted = plan_logs(50, seed=1, gain_drift=0.1)
    np.testing.assert_allclose([p.K for p in drifted], ks * 1.1)
    assert all(len(p.changes) == 4 and p.u0 != 0 for p in plans)
    assert all(10 <= level <= 90 for p in plans for _, level in p.changes)


def test_identified_gain_matches_truth():
    for plan in plan_logs(3, seed=2):
        rec = log_record(plan)
        fit = identify(event_data(rec.t, rec.u, rec.y), "first_order")
        assert fit.ok
        assert fit.model.params["K"] == pytest.approx(plan.K, rel=0.02)
        assert fit.model.params["T"] == pytest.approx(plan.T, rel=0.12)


def test_corrupt_files_are_bad_in_varied_ways(tmp_path):
    n = 12
    paths = write_synthetic_logs(tmp_path, n, seed=4, corrupt=5)
    plans = plan_logs(n, seed=4, corrupt=5)
    kinds = {p.name: p.corruption for p in plans if p.corruption}
    assert sorted(kinds.values()) == sorted(CORRUPTIONS)
    # the same files are corrupted whatever the noise
    assert kinds == {p.name: p.corruption for p in plan_logs(n, seed=4, corrupt=5,
                                                              noise_seed=1) if p.corruption}
    for path in paths:
        data = path.read_bytes()
        kind = kinds.get(path.stem)
        if kind is None:
            frame = pl.read_csv(path)
            assert frame.columns == ["time", "u", "y"] and frame.height > 1000
            assert frame.dtypes == [pl.Float64] * 3
        elif kind == "empty":
            assert data == b""
        elif kind == "binary":
            with pytest.raises(UnicodeDecodeError):
                data.decode("utf-8")
        elif kind == "missing_output":
            assert data.splitlines()[0] == b"time,u"
        elif kind == "non_numeric":
            assert b",ERR\n" in data
        elif kind == "truncated":
            assert data.rstrip(b"\n").splitlines()[-1].count(b",") == 1
            assert data.endswith(b",")


def test_corrupt_count_is_checked(tmp_path):
    with pytest.raises(UserError, match="corrupt must be between 0 and n=2, got 3"):
        plan_logs(2, corrupt=3)


def test_corrupted_files_fail_through_the_loader(tmp_path):
    """Every corruption is caught by the CSV loader with a one-line reason."""
    from pipeline.config import config_from_dict
    from pipeline.run import RecordSpec, process_record

    paths = write_synthetic_logs(tmp_path, 6, seed=5, corrupt=5, n_steps=2)
    cfg = config_from_dict({"data": {"path": str(tmp_path), "input": "u", "output": "y",
                                     "time": "time"}}, base_dir=str(tmp_path))
    plans = plan_logs(6, seed=5, corrupt=5, n_steps=2)
    for path, plan in zip(paths, plans, strict=True):
        res = process_record(RecordSpec(path.stem, str(path)), cfg)
        assert res.ok == (plan.corruption is None), (plan.corruption, res.error)
        if not res.ok:
            assert "\n" not in res.error and str(path) in res.error


def test_nights(tmp_path):
    dirs = write_nights(tmp_path, nights=3, drift_per_night=0.05, n=2)
    assert [d.name for d in dirs] == ["night_01", "night_02", "night_03"]
    assert all(len(list(d.glob("*.csv"))) == 2 for d in dirs)
    assert [night_drift(k, 0.05) for k in range(3)] == [0.0, 0.05, 0.1]
    y = [pl.read_csv(d / "log_000.csv").get_column("y").to_numpy() for d in dirs]
    u = [pl.read_csv(d / "log_000.csv").get_column("u").to_numpy() for d in dirs]
    np.testing.assert_array_equal(u[0], u[2])  # same experiment every night
    assert not np.array_equal(y[0], y[1])  # fresh noise and a drifting gain
