"""Grading: flags raised where they belong and not elsewhere, verdicts from their severity."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.analysis import AnalysisOptions, analyse
from pipeline.fit import Flag
from pipeline.grading.verdicts import FLAGS, verdict_of
from pipeline.models import ProcessModel
from pipeline.record import make_record
from pipeline.synth import response, staircase, step_record
from pipeline.synth.closed_loop import pi_loop_record

FOPDT = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 1.0})
FIRST = ("first_order",)


def codes(result, method: str = "first_order", event: int = 0) -> set[str]:
    fit = result.fit(method, event)
    assert fit is not None and fit.ok, fit
    return {f.code for f in fit.flags}


def test_verdict_is_the_worst_severity():
    w, u = Flag("poor_fit", "m"), Flag("negative_fit", "m", severity="unreliable")
    assert verdict_of([]) == "ok" and verdict_of([w]) == "warning"
    assert verdict_of([w, u]) == "unreliable"


def test_clean_settled_step_has_no_flags():
    rec = step_record(FOPDT, u0=2.0, changes=[(20.0, 5.0), (150.0, 3.0)], t_end=280.0,
                      dt=0.1, y0=7.0, noise=0.03, seed=1)
    res = analyse(rec, AnalysisOptions(methods=FIRST))
    fit = res.fit("first_order", 0)
    assert fit.verdict == "ok", [f.message for f in fit.flags]


def test_short_window_is_unsettled():
    """A window of 1.5 T: the graphical gain is a lower bound."""
    rec = step_record(FOPDT, u0=2.0, changes=[(20.0, 5.0)], t_end=35.0, dt=0.1, y0=7.0,
                      noise=0.02, seed=2)
    res = analyse(rec, AnalysisOptions(methods=FIRST))
    assert "unsettled" in codes(res)
    flag = next(f for f in res.fit("first_order", 0).flags if f.code == "unsettled")
    assert "lower bound" in flag.message and flag.values["window"] == pytest.approx(15, abs=0.2)


def test_drifting_baseline_is_flagged():
    """A 45-minute warm-up still creeping when the step comes: y0 is biased."""
    t = np.arange(0.0, 300.0, 0.5)
    u = staircase(t, 2.0, [(150.0, 5.0)])
    drift = 3.0 * (1.0 - np.exp(-(t + 60.0) / 200.0))  # the tail of a slow warm-up
    y = response(FOPDT, t, u, 2.0, 7.0, noise=0.02, seed=3) + drift
    res = analyse(make_record(t, u, y, name="warm", source="<warm>"),
                  AnalysisOptions(methods=FIRST))
    assert "baseline_not_steady" in codes(res)
    flat = step_record(FOPDT, u0=2.0, changes=[(150.0, 5.0)], t_end=300.0, dt=0.5, y0=7.0,
                       noise=0.02, seed=3)
    assert "baseline_not_steady" not in codes(analyse(flat, AnalysisOptions(methods=FIRST)))


def test_dynamics_below_the_sample_time():
    fast = ProcessModel("first_order", {"K": 2.0, "T": 0.0046})
    rec = step_record(fast, u0=0.0, changes=[(0.5, 1.0)], t_end=1.0, dt=0.005, y0=1.0,
                      noise=0.001, seed=4)
    res = analyse(rec, AnalysisOptions(methods=("first_order_two_point", "viteckova1")))
    flagged = [f for f in res.fits if f.ok and
               any(x.code == "dynamics_below_sample_time" for x in f.flags)]
    assert flagged
    assert "shorter than the sample time" in flagged[0].flags[0].message or any(
        "shorter than the sample time" in x.message for x in flagged[0].flags)


def test_clipped_delay_is_flagged():
    """Two lags without delay read by a first-order two-point method: the implied delay of
    a slower-than-first-order rise is positive; a fast initial rise (a zero) makes it
    negative, and the method clips it."""
    lead = ProcessModel("two_lags", {"K": 2.0, "T1": 10.0, "T2": 0.2})
    rec = step_record(lead, u0=0.0, changes=[(10.0, 1.0)], t_end=120.0, dt=0.05, y0=0.0)
    t = rec.t
    y = rec.y + 0.4 * (t >= 10.0) * np.exp(-(t - 10.0) / 2.0)  # an early bump: a zero
    res = analyse(make_record(t, rec.u, y, name="z", source="<z>"),
                  AnalysisOptions(methods=("viteckova1",)))
    assert "delay_clipped" in codes(res, "viteckova1")


def record_codes(result) -> set[str]:
    return {f.code for f in result.flags}


def test_closed_loop_rate_and_open_loop_false_alarms():
    """A PI loop on an FOPDT plant, setpoint steps, the controller output logged as the
    input: at least 90 % of 50 logs (varied plants, noise) flagged, on the record and on its
    fits; none of 50 open-loop step tests with input noise flagged."""
    hits = 0
    for s in range(50):
        rec = pi_loop_record(noise=0.2 + 0.01 * s, seed=100 + s, K=1.5 + 0.02 * s,
                             delay=0.5 + 0.03 * s)
        res = analyse(rec, AnalysisOptions(methods=FIRST))
        flagged = "closed_loop_suspected" in record_codes(res)
        hits += flagged
        if flagged:
            assert all(any(x.code == "closed_loop_suspected" for x in f.flags)
                       for f in res.fits if f.ok)
    assert hits >= 45
    # a reverse-acting plant under its (reverse-acting) controller
    assert all("closed_loop_suspected" in record_codes(analyse(
        pi_loop_record(noise=0.3, seed=s, K=-2.0), AnalysisOptions(methods=FIRST)))
        for s in range(5))
    false = sum("closed_loop_suspected" in record_codes(analyse(step_record(
        FOPDT, u0=20.0, changes=[(20.0, 30.0), (120.0, 22.0), (220.0, 28.0)], t_end=300.0,
        dt=0.1, y0=40.0, noise=0.3, seed=s, input_noise=0.05),
        AnalysisOptions(methods=FIRST))) for s in range(50))
    assert false == 0


def test_every_flag_has_a_description():
    assert all(isinstance(v, str) and v for v in FLAGS.values())
    assert {"unsettled", "baseline_not_steady", "overshoot_within_noise",
            "dynamics_below_sample_time", "delay_clipped", "poor_fit", "negative_fit",
            "residuals_not_white", "wide_ci", "closed_loop_suspected", "gain_inconsistent",
            "direction_asymmetry"} <= set(FLAGS)


def _graded(model: ProcessModel, method: str = "first_order"):
    """A fit of ``model`` on a clean first-order step, scored and graded as analyse does."""
    from dataclasses import replace

    from pipeline.fit import Fit
    from pipeline.grading.verdicts import grade
    from pipeline.validate import score

    rec = step_record(FOPDT, u0=2.0, changes=[(20.0, 5.0), (150.0, 3.0)], t_end=280.0,
                      dt=0.1, y0=7.0, noise=0.03, seed=1)
    res = analyse(rec, AnalysisOptions(methods=FIRST, consistency=False))
    fit = Fit(method, 0, "ok", model=model,
              metrics=score(model, rec, res.events, res.events[0], [1]))
    return grade(replace(res, fits=[fit])).fits[0]


def test_a_wrong_gain_sign_is_unreliable():
    fit = _graded(ProcessModel("first_order", {"K": -2.0, "T": 10.0, "delay": 1.0}))
    assert fit.verdict == "unreliable" and "gain_sign_wrong" in {f.code for f in fit.flags}


def test_a_gross_misfit_is_unreliable_a_small_one_a_warning():
    far = _graded(ProcessModel("first_order", {"K": 2.0, "T": 60.0, "delay": 1.0}))
    near = _graded(ProcessModel("first_order", {"K": 2.0, "T": 10.6, "delay": 1.0}))
    (f,) = [x for x in far.flags if x.code == "residuals_not_white"]
    assert f.severity == "unreliable" and far.verdict == "unreliable"
    assert f.values["fit_percent"] < 50
    assert near.verdict in ("ok", "warning")
    assert not any(x.severity == "unreliable" for x in near.flags)


def test_flag_messages_speak_the_users_time_unit():
    rec = step_record(FOPDT, u0=2.0, changes=[(20.0, 5.0)], t_end=35.0, dt=0.1, y0=7.0,
                      noise=0.02, seed=2)
    rec = make_record(rec.t, rec.u, rec.y, name="m", source="<m>", units={"time": "min"})
    res = analyse(rec, AnalysisOptions(methods=FIRST))
    flag = next(f for f in res.fit("first_order", 0).flags if f.code == "unsettled")
    assert "0.25 min after the step" in flag.message


def test_a_wide_interval_reads_as_a_number_a_person_can_read():
    """An interval many orders wider than its value (a lag the data do not determine:
    seen on the tank pulse log) is said in times its value, not in a 300-digit
    percentage; up to 1000 % in percent."""
    from dataclasses import replace

    base = _graded(ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 1.0}))
    from pipeline.grading.verdicts import _wide_ci

    rec = step_record(FOPDT, u0=2.0, changes=[(20.0, 5.0)], t_end=150.0, dt=0.1, y0=7.0)
    ev = analyse(rec, AnalysisOptions(methods=FIRST)).events[0]
    for half, text in ((1e302, "±1e+302 times its value"), (3.0, "±300% of its value"),
                       (102.07, "±102 times its value"), (4.8e306, "±4.8e+306 times")):
        fit = replace(base, ci95={"T": (10.0 - half * 10.0, 10.0 + half * 10.0)})
        flag = _wide_ci(fit, ev, rec)
        assert flag.severity == "warning"  # T from 0 (or its bound) to far out: it matters
        assert text in flag.message and len(flag.message) < 160, flag.message
