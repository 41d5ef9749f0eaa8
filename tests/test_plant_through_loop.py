"""The plant fitted through its closed loop, the controller known (issue 32 item 1, the
indirect approach), against known truth: the closed-loop bench's loops
(:func:`pipeline.synth.closed_loop.loop_record`), the controller read off each log."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from pipeline.cli import app
from pipeline.refine import fit_through_loop, loop_response
from pipeline.synth.closed_loop import LOOP_TUNINGS, loop_record, pi_loop_record
from pipeline.tuning import Controller, identify_controller, read_loop, with_plant

SETPOINTS = ((20.0, 55.0), (120.0, 47.0), (220.0, 52.0))
#: the bench's plants in the structure table: (structure, parameters, dominant lag)
TRUTH = {"fopdt": ("first_order", {"K": 2.0, "T": 10.0, "delay": 1.0}, "T"),
         "two_lags": ("two_lags", {"K": 1.0, "T1": 8.0, "T2": 3.0, "delay": 1.0}, "T1"),
         "integrator_lag": ("integrator_lag", {"K": 0.2, "T": 3.0, "delay": 2.0}, "T")}
LOOPS = [(p, k) for p in TRUTH for k in LOOP_TUNINGS[p]]
#: SIMC's PI for the first-order plant (tau_c = theta)
SIMC_KC, SIMC_TI = LOOP_TUNINGS["fopdt"]["PI"][:2]


def _setpoint(t: np.ndarray) -> np.ndarray:
    r = np.full(t.size, 50.0)
    for t_c, level in SETPOINTS:
        r[t >= t_c - 1e-9] = level
    return r


def _start(p: dict[str, float]) -> dict[str, float]:
    """A start off the truth: 30 % on the gain and the lags (the direct fit's place)."""
    return {k: v if k == "delay" else 1.3 * v for k, v in p.items()}


@pytest.mark.parametrize(("plant", "kind"), LOOPS)
def test_the_loop_filter_is_the_loop(plant, kind):
    """Noise-free, the closed loop simulated from the setpoint with the true plant and the
    controller read off the log is the bench's loop, to rounding."""
    structure, p, _ = TRUTH[plant]
    rec = loop_record(plant, kind, setpoints=SETPOINTS)
    r = _setpoint(rec.t)
    c = identify_controller(rec.t, r, rec.y, rec.u).controller
    sim = loop_response(structure, p, c, 0.1, r)
    assert np.max(np.abs(rec.y - rec.y[0] - sim)) < 1e-7 * np.ptp(rec.y)


def test_gain_and_lag_within_10_percent_and_intervals_that_cover():
    """Every bench loop with a plant in the structure table (P, PI, PID; SIMC and detuned
    2x), white and AR(1) (phi 0.9) measurement noise of 1 % of the first step, 10 seeds:
    K and the dominant lag within 10 % in at least 90 % of the seeds of each, and the
    95 % intervals of both covering the truth in 90-99 % of the 280 fits (measured: K
    and the lag within 10 % in all; coverage 95.7 % and 93.2 %)."""
    n = covered_k = covered_t = 0
    for plant, kind in LOOPS:
        structure, p, dom = TRUTH[plant]
        for detune in (1.0, 2.0):
            for phi in (0.0, 0.9):
                near = 0
                for seed in range(10):
                    rec = loop_record(plant, kind, detune=detune, noise=0.05, noise_phi=phi,
                                      seed=100 + seed, setpoints=SETPOINTS)
                    r = _setpoint(rec.t)
                    c = identify_controller(rec.t, r, rec.y, rec.u).controller
                    fit = fit_through_loop(rec.t, r, rec.y, c, structure, _start(p))
                    q = fit.model.params
                    near += abs(q["K"] / p["K"] - 1) <= 0.1 and abs(q[dom] / p[dom] - 1) <= 0.1
                    covered_k += fit.ci95["K"][0] <= p["K"] <= fit.ci95["K"][1]
                    covered_t += fit.ci95[dom][0] <= p[dom] <= fit.ci95[dom][1]
                    n += 1
                assert near >= 9, (plant, kind, detune, phi)
    assert n == 280
    assert 0.90 <= covered_k / n <= 0.99
    assert 0.90 <= covered_t / n <= 0.99


def test_the_p_loop_direct_fit_is_biased_and_the_loop_fit_is_not(tmp_path):
    """A P loop (Kc 3.68, 27 % overshoot) whose direct fit (controller output to
    measurement) is off the gain by more than 15 %, and not "ok"; fitted through the
    loop from it, the gain is within 2 %, the report line says the direct fit is biased,
    and the controller tuned from the loop's plant is SIMC's within 3 % and robust (from
    the direct fit: Ti 6.75 s, 16 % short, and fragile). The twin: the PI loop's direct
    fit is near, and so is the loop's."""
    runner = CliRunner()
    for kind, detune, biased in (("P", 0.68, True), ("PI", 1.0, False)):
        rec = loop_record("fopdt", kind, detune=detune, noise=0.05, seed=1,
                          setpoints=SETPOINTS)
        path = tmp_path / f"{kind}.csv"
        rows = zip(rec.t, _setpoint(rec.t), rec.u, rec.y, strict=True)
        path.write_text("time,r,u,y\n" + "".join(f"{a:.4f},{b:.6g},{c:.8g},{d:.8g}\n"
                                                 for a, b, c, d in rows))
        args = ["identify", str(path), "--input", "u", "--output", "y", "--time", "time",
                "--setpoint", "r"]
        r = runner.invoke(app, [*args, "--json"])
        assert r.exit_code == 0, r.output
        (doc,) = json.loads(r.stdout)["records"]
        plant = doc["running_loop"]["plant"]
        assert plant["structure"] == "first_order"
        assert plant["params"]["K"] == pytest.approx(2.0, rel=0.02)
        assert plant["params"]["T"] == pytest.approx(10.0, rel=0.02)
        lo, hi = plant["ci95"]["K"]
        assert lo <= 2.0 <= hi
        direct = doc["recommended"]
        assert (abs(direct["params"]["K"] / 2.0 - 1) > 0.15) == biased
        assert direct["verdict"] != "ok"
        # the controller is tuned from the plant through the loop: SIMC's own settings
        tuning = doc["tuning"]
        assert tuning["method"] == "plant_through_loop"
        assert tuning["controller"]["Kc"] == pytest.approx(SIMC_KC, rel=0.03)
        assert tuning["controller"]["Ti"] == pytest.approx(SIMC_TI, rel=0.03)
        assert tuning["verdict"] == "robust"
        out = tmp_path / f"out_{kind}"
        text = runner.invoke(app, [*args, "--out", str(out)]).stdout
        assert "plant through the loop" in text
        # pipeline tune on the results tunes from the same plant as the run did
        again = runner.invoke(app, ["tune", str(out / "results.json")])
        assert again.exit_code == 0, again.output
        assert f"Kc {tuning['controller']['Kc']:.4g}" in again.stdout
        if biased:
            assert "has K, T, delay outside them: its estimate is biased by the loop" in text


def test_what_cannot_be_fitted_says_why():
    rec = loop_record("fopdt", "PI", noise=0.05, seed=3, setpoints=SETPOINTS)
    r = _setpoint(rec.t)
    reading = read_loop(rec.t, r, rec.y, rec.u)
    chain = with_plant(reading, rec.t, r, rec.y, "n_lags", {"K": 2.0, "T": 3.0, "n": 3.0,
                                                             "delay": 1.0})
    assert chain.plant is None and "no exact discrete filter" in chain.plant_reason
    # settings that do not explain the controller output (an output limited at 26):
    # the loop is not known, so the plant is not fitted through it
    limited = read_loop(rec.t, r, rec.y, np.minimum(rec.u, 26.0))
    out = with_plant(limited, rec.t, r, rec.y, "first_order", TRUTH["fopdt"][1])
    assert out.plant is None and "not known well enough" in out.plant_reason
    with pytest.raises(ValueError, match="uniformly"):
        fit_through_loop(rec.t + np.r_[0.0, np.full(rec.t.size - 1, 0.03)] * (
            np.arange(rec.t.size) % 2), r, rec.y, Controller.ideal(2.5, 8.0), "first_order",
            TRUTH["fopdt"][1])


def test_the_gain_sign_is_the_controllers():
    """A plant of gain -2 under a direct-acting PI (Kc -2.5): from a start of the wrong
    sign (a direct fit's classic failure in closed loop), the fit still finds -2."""
    rec = loop_record("fopdt", "PI", detune=-1.0, gain=-1.0, noise=0.05, seed=4,
                      setpoints=SETPOINTS)
    r = _setpoint(rec.t)
    c = identify_controller(rec.t, r, rec.y, rec.u).controller
    assert c.Kc == pytest.approx(-2.5, rel=1e-6)
    for k0 in (-2.6, 2.6):
        fit = fit_through_loop(rec.t, r, rec.y, c, "first_order",
                               {"K": k0, "T": 13.0, "delay": 1.0})
        assert fit.model.params["K"] == pytest.approx(-2.0, rel=0.02)
        lo, hi = fit.ci95["K"]
        assert lo <= -2.0 <= hi < 0


def test_an_order_held_lags_in_order_and_a_dead_time_not_below_zero():
    rec = loop_record("two_lags", "PI", noise=0.05, seed=5, setpoints=SETPOINTS)
    r = _setpoint(rec.t)
    c = identify_controller(rec.t, r, rec.y, rec.u).controller
    for n in (1.0, 2.0):  # an equal-lag chain's order, as the refinement rounded it
        fit = fit_through_loop(rec.t, r, rec.y, c, "n_lags",
                               {"K": 1.2, "T": 5.0, "n": n, "delay": 1.0})
        assert fit.model.params["n"] == n and "n" not in fit.ci95
        assert all(v > 0 and np.isfinite(v) for v in fit.std.values())
    # from a start with the lags the other way round (T1 < T2), T1 is the larger
    fit = fit_through_loop(rec.t, r, rec.y, c, "two_lags",
                           {"K": 1.3, "T1": 3.0, "T2": 10.0, "delay": 1.0})
    assert fit.model.params["T1"] == pytest.approx(8.0, rel=0.1)
    assert fit.model.params["T2"] == pytest.approx(3.0, rel=0.1)
    assert fit.ci95["T1"][0] > fit.ci95["T2"][1]
    # a plant without dead time: the interval of its dead time starts at 0, not below
    fast = pi_loop_record(K=2.0, T=10.0, delay=0.0, Kc=2.5, Ti=8.0, noise=0.2, seed=4)
    r0 = np.full(fast.t.size, 50.0)
    for t_c, level in ((20.0, 60.0), (120.0, 45.0), (220.0, 55.0)):  # its defaults
        r0[fast.t >= t_c - 1e-9] = level
    c = identify_controller(fast.t, r0, fast.y, fast.u).controller
    fit = fit_through_loop(fast.t, r0, fast.y, c, "first_order",
                           {"K": 2.2, "T": 11.0, "delay": 0.05})
    assert fit.model.params["K"] == pytest.approx(2.0, rel=0.05)
    assert fit.model.params["delay"] < 0.1
    assert fit.ci95["delay"][0] == 0.0 <= fit.ci95["delay"][1]


def test_no_setpoint_change_and_direct_feedthrough_are_refused():
    rec = loop_record("fopdt", "PI", noise=0.05, seed=3, setpoints=SETPOINTS,
                      loads=((100.0, 0.5),))
    c = Controller.ideal(2.5, 8.0)
    with pytest.raises(ValueError, match="never changes"):
        fit_through_loop(rec.t, np.full(rec.t.size, 50.0), rec.y, c, "first_order",
                         TRUTH["fopdt"][1])
    with pytest.raises(ValueError, match="direct feedthrough"):
        fit_through_loop(rec.t, _setpoint(rec.t), rec.y, c, "lead_lag",
                         {"K": 2.0, "Tz": 4.0, "T": 10.0, "delay": 0.0})


def test_a_structure_that_cannot_be_closed_falls_back_to_the_next_refinement():
    """The recommended direct fit's structure has no exact filter to close the loop with
    (three equal lags): the plant is fitted through the loop from the event's next
    refinement (first order), right within 2 %; with no other refinement, the reason."""
    from dataclasses import replace

    from pipeline.analysis import AnalysisOptions, _through_loop, analyse
    from pipeline.models import ProcessModel
    from pipeline.record import with_setpoint

    rec = loop_record("fopdt", "PI", noise=0.05, seed=7, setpoints=SETPOINTS)
    rec = with_setpoint(rec, _setpoint(rec.t), "r")
    for methods, fallback in ((("lsq_first_order", "lsq_n_lags"), True),
                              (("lsq_n_lags",), False)):
        res = analyse(rec, AnalysisOptions(methods=methods, tuning=None))
        chain = res.fit("lsq_n_lags", res.recommended.event)
        three = replace(chain, model=ProcessModel("n_lags", {**chain.model.params,
                                                             "n": 3.0}))
        loop = _through_loop(replace(res, loop=replace(res.loop, plant=None)), rec,
                             three).loop
        if fallback:
            assert loop.plant.model.structure == "first_order"
            assert loop.plant.model.params["K"] == pytest.approx(2.0, rel=0.02)
        else:
            assert loop.plant is None and "no exact discrete filter" in loop.plant_reason
