"""One synthetic log in every supported form gives the same events and first-order
parameters as the plain CSV, through the real analysis path (pipeline.analysis.analyse)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.io import DataConfig, load_record
from tests.forms import FORMS, synthetic_log

METHODS = ("first_order", "first_order_two_point")
EVENT_FIELDS = ("t0", "u0", "u_ss", "y0", "y_ss")


def _result(path: Path, keys: dict):
    record = load_record(path, DataConfig(path=str(path), **keys))
    return record, analyse(record, AnalysisOptions(events=(0,), methods=METHODS))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    folder = tmp_path_factory.mktemp("forms")
    writer, _ = FORMS["csv_header"]
    return folder, _result(*writer(synthetic_log(), folder))


@pytest.mark.parametrize("form", FORMS)
def test_every_form_gives_the_plain_csv_result(form, reference):
    folder, (_, ref) = reference
    writer, tol = FORMS[form]
    record, res = _result(*writer(synthetic_log(), folder))
    assert res.error is None, res.error
    assert len(res.events) == len(ref.events) == 2
    for e, r in zip(res.events, ref.events, strict=True):
        for f in EVENT_FIELDS:
            assert getattr(e, f) == pytest.approx(getattr(r, f), rel=tol, abs=tol), (form, f)
    for fit, want in zip(res.fits, ref.fits, strict=True):
        assert fit.status == want.status == "ok", (form, fit.method, fit.reason)
        for k, v in want.model.params.items():
            assert fit.model.params[k] == pytest.approx(v, rel=tol, abs=tol), (form, k)
