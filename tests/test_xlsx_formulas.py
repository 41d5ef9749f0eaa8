"""The formula check streams the sheet (issue 31): a formula element cut between two
chunks is found, and a workbook without formulas is never parsed (the corpus rows in
``tests/corpus/workbooks.py`` run the CLI)."""

from __future__ import annotations

import pytest

from pipeline.io import excel
from tests.corpus.workbooks import _as_saved, _placeholders, _workbook


@pytest.mark.parametrize("chunk", [5, 7, 64, 1 << 20])
def test_a_formula_is_found_whatever_the_chunk(tmp_path, monkeypatch, chunk):
    monkeypatch.setattr(excel, "CHUNK", chunk)
    bad, good, plain = tmp_path / "bad.xlsx", tmp_path / "good.xlsx", tmp_path / "plain.xlsx"
    bad.write_bytes(_placeholders(_workbook(formulas=True)))
    good.write_bytes(_as_saved(_workbook(formulas=True)))
    plain.write_bytes(_workbook(formulas=False))
    assert excel.uncalculated_formula(bad, "log") == "C2"
    assert excel.uncalculated_formula(good, "log") is None
    assert excel.uncalculated_formula(plain, "log") is None
    assert excel.uncalculated_formula(bad, "no such sheet") is None
