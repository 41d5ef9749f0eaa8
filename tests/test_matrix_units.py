"""A MATLAB matrix's columns (``data[0]``, ``data[2]``) are positions, not units (issue 29:
"K = 0.53 1/2" from ``result[1]`` and ``result[2]``); a header's ``[degC]`` still is."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.io import savemat

import pipeline
from pipeline.io.table import split_unit


def test_an_index_is_no_unit():
    assert split_unit("result[2]") == ("result[2]", None)
    assert split_unit("x(3)") == ("x(3)", None)
    assert split_unit("T [degC]") == ("T", "degC")
    assert split_unit("Zeit (s)") == ("Zeit", "s")
    assert split_unit("eta [1]") == ("eta", "1")  # a space: a dimensionless unit


def test_matrix_columns_name_signals_without_units(tmp_path):
    t = np.arange(0.0, 200.0, 1.0)
    u = np.where(t >= 20.0, 1.0, 0.0)
    y = 4.0 + 0.53 * (1.0 - np.exp(-np.clip(t - 20.0, 0.0, None) / 10.0))
    p = tmp_path / "m.mat"
    savemat(p, {"result": np.c_[t, u, y]})
    rec = pipeline.load(p, time="result[0]", input="result[1]", output="result[2]")
    assert "input" not in rec.units and "output" not in rec.units
    res = pipeline.analyse(rec)
    assert res.recommended.model.K == pytest.approx(0.53, rel=0.01)
