"""The regression gate on closed-loop logs read with their setpoint (issue 32 item 3): the
plant fitted through the loop drifting is a regression, fresh noise on the same loop is
not, and a retuned controller is information. Known truth: the closed-loop bench's PI
loop around ``K e^-s/(10 s + 1)``, K 2 (2.4 after a drift)
(:func:`pipeline.synth.closed_loop.loop_record`)."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.gate.baseline import Tolerances, compare
from pipeline.record import with_setpoint
from pipeline.schema import ResultsDoc
from pipeline.synth.closed_loop import loop_record

SETPOINTS = ((20.0, 55.0), (120.0, 47.0), (220.0, 52.0))


def _night(gain: float = 2.0, seed: int = 1, detune: float = 1.0) -> ResultsDoc:
    """One night's results of the PI loop around ``gain e^-s/(10 s + 1)``."""
    rec = loop_record("fopdt", "PI", detune=detune, noise=0.05, seed=seed,
                      setpoints=SETPOINTS, name="loop", gain=gain / 2.0)
    r = np.full(rec.t.size, 50.0)
    for t_c, level in SETPOINTS:
        r[rec.t >= t_c - 1e-9] = level
    res = analyse(with_setpoint(rec, r, "r"), AnalysisOptions(tuning=None))
    return ResultsDoc(pipeline_version="test", records=[res.to_doc()])


def test_the_plant_through_the_loop_drifting_is_a_regression():
    base = _night()
    same = compare(_night(seed=2), base, Tolerances())
    assert not [f for f in same.regressions if f.kind == "loop_plant_drift"]
    drift = compare(_night(gain=2.4, seed=2), base, Tolerances())
    found = [f for f in drift.regressions if f.kind == "loop_plant_drift"]
    assert [f.parameter for f in found] == ["K"]
    assert found[0].baseline_value == pytest.approx(2.0, rel=0.02)
    assert found[0].current_value == pytest.approx(2.4, rel=0.02)
    assert not drift.ok


def test_a_retuned_controller_is_information():
    base = _night()
    retuned = compare(_night(seed=2, detune=2.0), base, Tolerances())
    info = [f for f in retuned.new if f.parameter == "running controller Kc"]
    assert len(info) == 1 and "retuned" in info[0].message
    assert info[0].current_value / info[0].baseline_value == pytest.approx(
        0.5, rel=1e-3)
    assert not [f for f in retuned.regressions if f.kind == "loop_plant_drift"]
