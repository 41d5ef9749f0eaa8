"""Identification on one event, validation on the others (issue 2)."""

import numpy as np
import pytest

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.models import ProcessModel
from pipeline.synth import step_record


def test_two_steps_validation_mse_equals_noise_variance():
    """Identify on the first step, validate on the second: with the right model the
    validation residual is the noise, so MSE = noise variance (within 20 %)."""
    truth = ProcessModel("first_order", {"K": 2.5, "T": 7.0})
    noise = 0.05
    rec = step_record(truth, u0=1.5, changes=[(13.7, 3.5), (113.7, 2.0)], t_end=213.7,
                      dt=0.05, y0=-4.0, noise=noise, seed=11)
    res = analyse(rec, AnalysisOptions(methods=("first_order",)))
    assert res.roles == {0: "identification", 1: "validation"}
    (fit,) = res.fits
    assert fit.ok
    assert fit.model.params["K"] == pytest.approx(2.5, rel=0.02)
    assert fit.metrics["mse_validation"] == pytest.approx(noise**2, rel=0.2)
    y_val = rec.y[res.events[1].i_start:]
    expected_fit = 100 * (1 - noise / np.std(y_val))  # NRMSE fit when the residual is noise
    assert fit.metrics["fit_percent"] == pytest.approx(expected_fit, abs=1.0)


def test_validation_starts_at_each_runs_operating_point():
    """Validation events that are not contiguous are simulated run by run."""
    truth = ProcessModel("first_order", {"K": 2.0, "T": 3.0})
    rec = step_record(truth, u0=0.0, changes=[(10, 1.0), (60, 3.0), (110, 2.0)], t_end=160,
                      dt=0.05, y0=5.0)
    res = analyse(rec, AnalysisOptions(events=(1,), methods=("first_order",)))
    (fit,) = res.fits
    assert res.roles == {0: "validation", 1: "identification", 2: "validation"}
    assert fit.metrics["mse_validation"] < 1e-6
    assert fit.metrics["ise"] < 1e-5


def test_missing_identification_event_is_a_record_error():
    truth = ProcessModel("first_order", {"K": 2.0, "T": 3.0})
    rec = step_record(truth, u0=0.0, changes=[(10, 1.0)], t_end=60, dt=0.1, y0=0.0)
    res = analyse(rec, AnalysisOptions(events=(3,)))
    assert res.error and "event 3 does not exist" in res.error


def test_step_near_the_end_gives_no_silent_model():
    truth = ProcessModel("first_order", {"K": 2.0, "T": 10.0})
    rec = step_record(truth, u0=0.0, changes=[(10, 1.0), (99.0, 2.0)], t_end=99.5, dt=0.5,
                      y0=0.0)
    res = analyse(rec, AnalysisOptions(events=(1,)))
    assert res.fits and all(f.status == "not_applicable" for f in res.fits)
    assert "window too short" in res.fits[0].reason


def test_a_method_bug_fails_that_fit_only(monkeypatch):
    from dataclasses import replace as dc_replace

    from pipeline.methods import REGISTRY

    def broken(ev):
        raise KeyError("bug")

    monkeypatch.setitem(REGISTRY, "first_order",
                        dc_replace(REGISTRY["first_order"], func=broken))
    truth = ProcessModel("first_order", {"K": 2.0, "T": 3.0})
    rec = step_record(truth, u0=0.0, changes=[(10, 1.0)], t_end=60, dt=0.1, y0=0.0)
    res = analyse(rec)
    status = {f.method: f.status for f in res.fits}
    assert status["first_order"] == "failed" and status["viteckova1"] == "ok"


def _restart_from_rest(model, rec, events, validation):
    """The old validation: each run of validation events from rest at its (u0, y0)."""
    from pipeline.simulation.engine import simulate
    from pipeline.validate import validation_runs

    errs = []
    for a, b, first in validation_runs(events, validation):
        sim = simulate(model, rec.t[a:b], rec.u[a:b], first.u0, first.y0)
        errs.append(rec.y[a:b] - sim)
    e = np.concatenate(errs)
    return float(np.mean(e * e))


def test_validation_is_continuous_when_the_plant_is_still_moving():
    """Steps 1.5 T apart: at each validation step the plant is still moving. The true
    model scores the noise variance when simulated continuously; restarted from rest at
    each run's operating point it scored a false start, dozens of times worse."""
    from pipeline.segmentation.detect import segment
    from pipeline.validate import score

    truth = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 1.0})
    noise = 0.03
    rec = step_record(truth, u0=1.0, changes=[(10, 2.0), (25, 3.0), (55, 1.5), (70, 2.5)],
                      t_end=120, dt=0.25, y0=3.0, noise=noise, seed=2)
    events = segment(rec)
    validation = [1, 3]  # two runs, each starting on the previous step's tail
    assert not events[0].settled and not events[2].settled
    m = score(truth, rec, events, events[0], validation)
    assert m["mse_validation"] == pytest.approx(noise**2, rel=0.2)
    assert _restart_from_rest(truth, rec, events, validation) > 30 * noise**2


def test_warmup_offset_absorbs_a_level_shift_before_validation():
    """An unmodelled output shift (a disturbance) after identification: the continuous
    simulation is off by it, the warm-up before the validation step measures it."""
    from pipeline.segmentation.detect import segment
    from pipeline.validate import score, warmup

    truth = ProcessModel("first_order", {"K": 2.0, "T": 3.0})
    noise = 0.02
    rec = step_record(truth, u0=0.0, changes=[(10, 1.0), (70, 3.0)], t_end=130, dt=0.1,
                      y0=5.0, noise=noise, seed=4)
    y = rec.y + np.where(rec.t > 45, 0.8, 0.0)
    from pipeline.record import make_record

    shifted = make_record(rec.t, rec.u, y, name="shift", source="<shift>")
    events = segment(shifted)
    w = warmup(events, events[1])
    assert shifted.t[w.start] > 45 and w.stop == events[1].i_start
    m = score(truth, shifted, events, events[0], [1])
    assert m["mse_validation"] == pytest.approx(noise**2, rel=0.25)
