"""The tuning of a model end to end: verdicts over the interval, the Ms target, forms and
units, results.json, the config block, the CLI command and the history columns."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

import pipeline
from pipeline.config import config_from_dict
from pipeline.errors import UserError
from pipeline.gate.history import history_rows
from pipeline.models import ProcessModel
from pipeline.results import RunResult, parse_results, results_json
from pipeline.run import analysis_options
from pipeline.tuning import TuningOptions, parameter_sets, tune, worst_case

PLANT = ProcessModel("first_order", {"K": 2.0, "T": 10.0, "delay": 1.0})
#: SIMC's tau_c = theta asked for by name: kept whatever the check over the interval says
TIGHT = TuningOptions(tau_c="tight")


def box(rel_k: float, rel_t: float, rel_d: float) -> dict[str, tuple[float, float]]:
    return {"K": (2 * (1 - rel_k), 2 * (1 + rel_k)), "T": (10 * (1 - rel_t), 10 * (1 + rel_t)),
            "delay": (1 - rel_d, 1 + rel_d)}


def test_verdict_follows_the_worst_case_over_the_interval():
    tight = tune(PLANT, ci95=box(0.01, 0.01, 0.01))
    assert tight.verdict == "robust" and tight.worst.ms <= 2.0
    # tau = 10 theta: Ti = 8 theta < tau, Ms a little above the 1.59 of tau <= 8 theta
    assert 1.59 < tight.margins.ms < 1.65
    wide = tune(PLANT, TIGHT, ci95=box(0.10, 0.10, 0.20))
    assert wide.verdict == "fragile" and wide.worst.ms > 2.0 and wide.worst.stable
    # the worst corner: the largest gain and dead time, the shortest lag
    assert wide.worst.params == {"K": 2.2, "T": 9.0, "delay": 1.2}
    # beside fragile settings, the robust choice of tau_c: slower than tau_c = theta, the
    # worst case at the default target
    assert tight.alternative is None
    alt = wide.alternative
    assert alt.tau_c > 1.0 and wide.alternative_ms == pytest.approx(1.7, abs=0.02)
    assert worst_case(PLANT, alt.controller, parameter_sets(PLANT, box(0.10, 0.10, 0.20))
                      ).ms == pytest.approx(wide.alternative_ms)
    assert "tau_c: robust" in wide.reasons[-1]
    # a dead time that may be three times longer destabilises SIMC's tight PI (its delay
    # margin is about twice the dead time)
    assert tune(PLANT).margins.delay_margin == pytest.approx(2.0, rel=0.02)
    huge = tune(PLANT, TIGHT, ci95={"delay": (0.5, 3.5)})
    assert huge.verdict == "unstable_in_interval" and huge.worst.stable_fraction < 1.0
    # the long end of the dead time's interval is the one unstable corner; no draws
    assert (huge.worst.n_corners, huge.worst.unstable_corners, huge.worst.unstable_draws) \
        == (2, 1, 0)
    assert "1 of the 2 corners" in huge.reasons[0]
    assert wide.replaced is None and huge.replaced is None


def test_default_tau_c_gives_way_to_the_robust_one_over_a_wide_interval():
    # tau_c not given: SIMC's tau_c = theta is fragile (worst-case Ms above 2) or unstable
    # over the interval, so the settings given are the robust choice, the default kept
    # beside them with its verdict
    ci = box(0.10, 0.10, 0.20)
    tight = tune(PLANT, TIGHT, ci95=ci)
    t = tune(PLANT, ci95=ci)
    assert t.verdict == "robust" and t.alternative is None
    assert t.settings.tau_c < tight.alternative.tau_c  # the limit 2.0, not the target 1.7
    assert t.worst.ms == pytest.approx(2.0, abs=0.02) and t.worst.ms <= 2.0
    r = t.replaced
    assert r.verdict == "fragile" and r.settings.tau_c == pytest.approx(1.0)
    assert r.settings.controller == tight.controller and r.worst_ms == pytest.approx(
        tight.worst.ms)
    assert "default tau_c (1 s" in t.reasons[0] and "fragile" in t.reasons[0]
    # the settings' spread: Kc = T/(K (tau_c + theta)) per set with the chosen tau_c;
    # the default's, with tau_c = theta per set, is kept beside it (the gate reads it)
    tc = t.settings.tau_c
    assert t.spread["Kc"] == (pytest.approx(9.0 / (2.2 * (tc + 1.2))),
                              pytest.approx(11.0 / (1.8 * (tc + 0.8))))
    assert r.spread == tight.spread
    # unstable over the interval: replaced too; the worst-case Ms of the default is inf
    huge = tune(PLANT, ci95={"delay": (0.5, 3.5)})
    assert huge.verdict == "robust" and huge.replaced.verdict == "unstable_in_interval"
    assert huge.replaced.worst_ms == math.inf and huge.worst.stable
    # a narrow interval keeps the default; so do a tau_c in seconds and an Ms target
    assert tune(PLANT, ci95=box(0.01, 0.01, 0.01)).replaced is None
    assert tune(PLANT, TuningOptions(tau_c=1.0), ci95=ci).verdict == "fragile"
    assert tune(PLANT, TuningOptions(ms_target=1.9), ci95=ci).replaced is None


def test_settings_spread_over_the_interval():
    # SIMC PI on K e^(-theta s)/(T s + 1), tau_c = theta: Kc = T/(2 K theta), Ti = min(T,
    # 8 theta); over the box the extremes sit at its corners
    t = tune(PLANT, TIGHT, ci95=box(0.10, 0.10, 0.20))
    lo, hi = t.spread["Kc"]
    assert lo == pytest.approx(9.0 / (2 * 2.2 * 1.2)) and hi == pytest.approx(
        11.0 / (2 * 1.8 * 0.8))
    assert t.spread["Ti"] == (pytest.approx(6.4), pytest.approx(9.6))
    assert "Td" not in t.spread and tune(PLANT).spread == {}
    # a tau_c given in seconds stays fixed over the sets: Kc = T/(K (tau_c + theta))
    fixed = tune(PLANT, TuningOptions(tau_c=2.0), ci95=box(0.0, 0.0, 0.20))
    assert fixed.spread["Kc"] == (pytest.approx(10 / (2 * 3.2)), pytest.approx(10 / (2 * 2.8)))


def test_no_interval_or_untrusted_model_is_never_robust():
    assert tune(PLANT).verdict == "unchecked"
    t = tune(PLANT, ci95=box(0.01, 0.01, 0.01), trusted=False,
             why_not="the model is flagged closed_loop_suspected")
    assert t.verdict == "unchecked" and "closed_loop_suspected" in t.reasons[0]
    # but an untrusted model's fragile settings are still called fragile
    assert tune(PLANT, TIGHT, ci95=box(0.1, 0.1, 0.2), trusted=False, why_not="x"
                ).verdict == "fragile"
    # and the robust choice in their place is unchecked, not robust
    t = tune(PLANT, ci95=box(0.1, 0.1, 0.2), trusted=False, why_not="x")
    assert t.replaced.verdict == "fragile" and t.verdict == "unchecked"


def test_ms_target_chooses_the_fastest_tau_c_that_keeps_the_worst_case():
    ci = box(0.10, 0.10, 0.20)
    t = tune(PLANT, TuningOptions(ms_target=1.7), ci95=ci)
    assert t.worst.ms <= 1.7 and t.worst.ms == pytest.approx(1.7, abs=0.02)
    assert t.settings.tau_c > 1.0  # slower than tight (tau_c = theta = 1)
    assert t.verdict == "robust"
    slower = tune(PLANT, TuningOptions(ms_target=1.4), ci95=ci)
    assert slower.settings.tau_c > t.settings.tau_c
    with pytest.raises(ValueError, match="AMIGO"):
        tune(PLANT, TuningOptions(rule="amigo", ms_target=1.7), ci95=ci)


def test_worst_case_matches_a_direct_check_of_every_set():
    from pipeline.tuning import nominal_margins
    from pipeline.tuning.robust import parameter_sets

    c = tune(PLANT).controller
    sets = parameter_sets(PLANT, box(0.1, 0.1, 0.2))
    w = worst_case(PLANT, c, sets)
    direct = max(nominal_margins(ProcessModel("first_order", p), c).ms for p in sets)
    assert w.ms == pytest.approx(direct, rel=0.01)
    assert w.n_sets == 1 + 8


def test_forms_units_and_action():
    opt = TuningOptions(form="parallel", time_unit="min", input_span=100.0, output_span=50.0)
    t = tune(ProcessModel("first_order", {"K": -2.0, "T": 10.0, "delay": 1.0}), opt)
    c = t.controller
    assert c.Kc < 0 and t.action == "direct"
    p = t.form()
    assert p["Kp"] == pytest.approx(abs(c.Kc))
    assert p["Ki"] == pytest.approx(abs(c.Kc) / c.Ti * 60.0)  # per minute
    assert t.form("ideal")["Ti"] == pytest.approx(c.Ti / 60.0)
    assert t.percent_gain == pytest.approx(abs(c.Kc) * 50.0 / 100.0)


def test_simulated_loop_settles_and_the_anti_windup_keeps_overshoot_small():
    t = tune(PLANT, ci95=box(0.01, 0.01, 0.01))
    r = t.response
    assert abs(r.y[-1] - r.r[-1]) < 0.01 * abs(r.r[-1])
    assert r.setpoint.overshoot < 0.15  # SIMC's tight PI: about 8 % (Skogestad 2003)
    assert t.worst_response is not None and t.worst_response.t[-1] == pytest.approx(r.t[-1],
                                                                          rel=1e-3)
    limited = tune(PLANT, ci95=box(0.01, 0.01, 0.01), r_step=1.0, u_limits=(-0.6, 0.6))
    assert limited.response.setpoint.saturated
    assert limited.response.setpoint.overshoot < 0.15


@pytest.fixture(scope="module")
def step_result():
    t = np.arange(0.0, 200.0, 0.5)
    u = np.where(t >= 10.0, 3.0, 1.0)
    y = 4.0 + 2.0 * (u - 1.0) * (1.0 - np.exp(-np.clip(t - 13.0, 0.0, None) / 15.0))
    y = y + np.random.default_rng(0).normal(0.0, 0.02, t.size)
    return pipeline.identify(t, u, y, methods=("lsq_first_order", "first_order"))


def test_identify_tunes_the_recommended_model(step_result):
    rt = step_result.tuning
    fit = step_result.recommended
    assert rt.ok and rt.method == fit.method
    t = rt.tuning
    # SIMC on K = 2, T = 15, theta = 3: Kc = 15/(2*6) = 1.25, Ti = min(15, 24) = 15
    assert t.controller.Kc == pytest.approx(1.25, rel=0.03)
    assert t.controller.Ti == pytest.approx(15.0, rel=0.03)
    assert t.verdict == "robust"
    # the loop runs mid-range: half the test's output change, the input's range
    assert rt.r_step == pytest.approx(2.0, rel=0.03)
    assert rt.u_limits == (pytest.approx(0.0, abs=0.1), pytest.approx(2.0, abs=0.1))


def test_results_json_carries_the_tuning(step_result):
    doc = parse_results(results_json(RunResult([step_result]).to_doc()))
    tu = doc.records[0].tuning
    assert tu.status == "ok" and tu.rule == "simc" and tu.kind == "PI"
    assert tu.controller.Kc == pytest.approx(step_result.tuning.tuning.controller.Kc)
    assert tu.margins.stable and tu.worst_case.n_sets > 100
    assert tu.response.setpoint.iae > 0
    rows = history_rows(doc, None)
    chosen = rows.filter(rows["recommended"])
    assert chosen["Kc"][0] == pytest.approx(tu.controller.Kc)
    assert chosen["Ti"][0] == pytest.approx(tu.controller.Ti)
    assert rows.filter(~rows["recommended"])["Kc"].is_null().all()


def test_config_tuning_block():
    base = {"data": {"path": "x.csv", "input": "u", "output": "y", "time": "t"}}
    cfg = config_from_dict({**base, "tuning": {"rule": "amigo", "form": "series",
                                               "time_unit": "min"}}, base_dir="/nonexistent")
    opt = analysis_options(cfg).tuning
    assert (opt.rule, opt.form, opt.time_unit) == ("amigo", "series", "min")
    robust = config_from_dict({**base, "tuning": {"tau_c": "robust", "ms_target": 1.5}},
                              base_dir="/nonexistent")
    assert analysis_options(robust).tuning.ms_target == 1.5
    off = config_from_dict({**base, "tuning": {"enabled": False}}, base_dir="/nonexistent")
    assert analysis_options(off).tuning is None
    with pytest.raises(UserError, match="tuning.rule"):
        config_from_dict({**base, "tuning": {"rule": "zn"}}, base_dir="/nonexistent")
    with pytest.raises(UserError, match="tuning.limits"):
        config_from_dict({**base, "tuning": {"limits": [5, 1]}}, base_dir="/nonexistent")


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "pipeline", *args], capture_output=True,
                          text=True, timeout=120)


def test_cli_tune_a_given_model():
    p = _cli("tune", "first_order", "K=2", "T=10", "delay=1")
    assert p.returncode == 0, p.stderr
    assert "Kc 2.5" in p.stdout and "Ti 8 s" in p.stdout and "unchecked" in p.stdout
    j = _cli("tune", "first_order", "K=2", "T=10", "delay=1", "--rule", "amigo", "--json")
    doc = json.loads(j.stdout)[0]["tuning"]
    assert doc["rule"] == "amigo" and doc["controller"]["Kc"] == pytest.approx(
        0.15 / 2 + (0.35 - 10 / 121) * 10 / 2, rel=1e-6)


@pytest.mark.parametrize("args, says", [
    (("first_ordr", "K=2", "T=1"), "did you mean first_order"),
    (("first_order", "K=2"), "needs T=..."),
    (("first_order", "K=2", "T=x"), "expected a number"),
    (("first_order", "K=2", "T=1", "zeta=1"), "no parameter 'zeta'"),
    (("first_order", "K=2", "T=1", "--rule", "zn"), "--rule"),
])
def test_cli_tune_bad_input_is_one_line_and_exit_2(args, says):
    p = _cli("tune", *args)
    assert p.returncode == 2
    assert says in p.stderr and len(p.stderr.strip().splitlines()) == 1
    assert "Traceback" not in p.stderr


def test_cli_tune_from_results_json(tmp_path, step_result):
    path = tmp_path / "results.json"
    path.write_text(results_json(RunResult([step_result]).to_doc()))
    p = _cli("tune", str(path), "--tau-c", "robust")
    assert p.returncode == 0, p.stderr
    assert "robust" in p.stdout and "Kc" in p.stdout
    assert math.isfinite(float(p.stdout.split("Kc ")[1].split()[0].rstrip(",")))


def test_a_dead_time_of_milliseconds_does_not_ask_for_an_extreme_gain():
    """Stop 40's case: a clean first-order log read with a dead time of 6.6 ms on a 0.1 s
    grid (its interval reaching 30 ms) gave SIMC's tight PI Kc 113 (T/(2 K theta)),
    unstable over the interval. The settings given hold there instead: a gain about a
    quarter of it (Kc 30), stable on every set, the default kept beside them."""
    m = ProcessModel("first_order", {"K": 2.0, "T": 3.0, "delay": 0.0066})
    ci = {"K": (1.98, 2.02), "T": (2.95, 3.05), "delay": (0.0, 0.03)}
    tight = tune(m, TIGHT, ci95=ci)
    assert tight.controller.Kc == pytest.approx(3.0 / (2 * 2.0 * 0.0066))
    assert tight.verdict in ("fragile", "unstable_in_interval")
    t = tune(m, ci95=ci)
    assert t.replaced.settings.controller == tight.controller
    assert t.verdict == "robust" and t.worst.stable and t.worst.ms <= 2.0
    assert t.controller.Kc < 0.3 * tight.controller.Kc
