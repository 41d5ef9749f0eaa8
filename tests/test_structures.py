"""The structure table's new entries (integrator, integrator_lag, zero_two_lags, lead_lag,
lag_second_order):
complete entries, closed forms against python-control, exact ZOH simulation on both
simulate paths, and the tables' readers (baseline gate, history, report)."""

import math

import control
import numpy as np
import pytest

from pipeline.gate.baseline import (
    param_scale,
    relative_change,
    step_response_distance,
    time_scale,
)
from pipeline.gate.history import SCHEMA
from pipeline.models import PARAMETERS, STRUCTURES, ProcessModel
from pipeline.report.tables import params_text
from pipeline.simulation.engine import pulse_response, simulate

NEW = {
    "integrator": {"K": 0.5},
    "integrator_lag": {"K": 0.5, "T": 4.0},
    "zero_two_lags": {"K": 2.0, "Tz": -3.0, "T1": 8.0, "T2": 2.0},
    "lead_lag": {"K": 2.0, "Tz": 6.0, "T": 3.0},
    "lag_second_order": {"K": 1.5, "T": 2.0, "zeta": 0.1, "wn": 1.5},
}
EXTRA = [
    # the most damped pair, its lag at 1/wn
    ProcessModel("lag_second_order", {"K": 1.0, "T": 0.5, "zeta": 0.99, "wn": 2.0}),
    ProcessModel("lag_second_order", {"K": -2.0, "T": 8.0, "zeta": 0.6, "wn": 3.0}),
    ProcessModel("zero_two_lags", {"K": -1.5, "Tz": 4.0, "T1": 2.0, "T2": 0.5}),  # lead
    ProcessModel("zero_two_lags", {"K": 1.0, "Tz": -2.0, "T1": 3.0, "T2": 3.0}),  # equal lags
    ProcessModel("lead_lag", {"K": 1.0, "Tz": -1.0, "T": 2.0}),  # jumps the wrong way
]
DT = 0.05


def _models(delays=(0.0, 1.0, 0.37)):
    out = [ProcessModel(s, {**p, "delay": d}) for s, p in NEW.items() for d in delays]
    return out + [ProcessModel(m.structure, {**m.params, "delay": d}) for m in EXTRA
                  for d in delays]


@pytest.mark.parametrize("name", list(NEW))
def test_entries_are_complete(name):
    s = STRUCTURES[name]
    p = {**NEW[name], "delay": 0.5}
    assert set(s.params) == set(p) and set(s.bounds) == set(s.params)
    assert all(q in PARAMETERS for q in s.params)
    assert s.order_class(p) in ("first", "second", "nth")
    assert s.time_scale(p) > 0 and s.text(p, 4)
    assert s.integrating == name.startswith("integrator")
    for q, (lo, hi) in s.bounds.items():
        assert lo <= p[q] <= hi
    num, den = s.num_den(p)
    assert num[-1] == pytest.approx(p["K"])  # the gain is in the numerator


def test_tz_parameter_and_integrating_gain_unit():
    tz = PARAMETERS["Tz"]
    assert (tz.kind, tz.tolerance, tz.scale) == ("time", "dynamics", "time_scale")
    units = {"time": "s", "input": "V", "output": "deg"}
    assert PARAMETERS["K"].unit(units, integrating=True) == "deg/V/s"
    assert PARAMETERS["K"].unit(units) == "deg/V"
    assert tz.unit(units) == "s"


@pytest.mark.parametrize("model", _models(delays=(0.0,)), ids=lambda m: m.text())
def test_closed_form_matches_python_control_step(model):
    """``step(p, t)`` against the continuous step response of ``num_den`` (python-control)."""
    t = np.linspace(0.0, 40.0, 4001)
    ref = control.step_response(model.transfer_function(), T=t).outputs
    assert np.max(np.abs(model.unit_step(t) - ref)) < 1e-6 * max(1.0, np.max(np.abs(ref)))


def test_lead_lag_jumps_at_zero_plus_and_ramps_are_exact():
    m = ProcessModel("lead_lag", {"K": 2.0, "Tz": 6.0, "T": 3.0, "delay": 1.0})
    assert m.unit_step(np.array([0.999, 1.0, 1.0 + 1e-9])) == pytest.approx([0, 4.0, 4.0])
    ramp = ProcessModel("integrator_lag", {"K": 0.5, "T": 4.0, "delay": 1.0})
    t = np.array([1.0, 101.0])
    assert ramp.unit_step(t) == pytest.approx([0.0, 0.5 * (100 - 4 * (1 - math.exp(-25)))])
    zero = ProcessModel("zero_two_lags", {**NEW["zero_two_lags"]})
    # initial slope K Tz/(T1 T2) and final value K
    assert zero.unit_step(np.array([1e-6]))[0] / 1e-6 == pytest.approx(2 * -3 / 16, rel=1e-4)
    assert zero.unit_step(np.array([400.0]))[0] == pytest.approx(2.0)


@pytest.mark.parametrize("model", _models(), ids=lambda m: m.text())
def test_simulated_steps_match_closed_form(model):
    """A step at a sample, from a nonzero operating point: exact on either path (lfilter
    for whole-sample delays, the pulse response for fractional ones)."""
    t = np.arange(1200) * DT
    u = np.where(np.arange(t.size) >= 100, 3.0, 1.0)
    y = simulate(model, t, u, 1.0, -4.0)
    exact = -4.0 + 2.0 * model.unit_step(t - 100 * DT)
    assert np.max(np.abs(y - exact)) < 1e-9 * max(1.0, np.max(np.abs(exact)))


@pytest.mark.parametrize("model", _models(delays=(0.0, 1.0)), ids=lambda m: m.text())
def test_both_paths_agree(model):
    """The lfilter path (whole-sample delays) and the pulse-response path give the same
    output on a random held input, the lead-lag's feedthrough included."""
    du = np.repeat(np.random.default_rng(5).normal(size=80), 10)
    y_lfilter = simulate(model, np.arange(du.size) * DT, du, 0.0, 0.0, dt=DT)
    y_pulse = np.convolve(du, pulse_response(model, DT, du.size))[: du.size]
    assert np.max(np.abs(y_lfilter - y_pulse)) < 1e-9 * max(1.0, np.max(np.abs(y_pulse)))


@pytest.mark.parametrize("model", _models(delays=(0.0, 1.0)), ids=lambda m: m.text())
def test_random_input_matches_python_control(model):
    rng = np.random.default_rng(1)
    t = np.arange(3000) * 0.01
    u = np.repeat(rng.normal(size=300), 10)
    y = simulate(model, t, u, 0.0, 0.0)
    sysd = control.c2d(model.transfer_function(), 0.01, "zoh")
    shift = round(model.delay / 0.01)
    ref = control.forced_response(sysd, t, np.concatenate([np.zeros(shift), u[: u.size - shift]]))
    assert np.max(np.abs(y - ref.outputs)) < 1e-8 * max(1.0, np.max(np.abs(y)))


def test_irregular_grid_is_exact_for_a_ramp():
    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.009, 0.011, 3000))
    u = np.where(t >= 5.0, 1.0, 0.0)
    m = ProcessModel("integrator_lag", {"K": 0.5, "T": 4.0, "delay": 0.3})
    y = simulate(m, t, u, 0.0, 2.0)
    assert np.max(np.abs(y - 2.0 - m.unit_step(t - t[np.argmax(t >= 5.0)]))) < 1e-12


# -- the tables' readers ------------------------------------------------------------------

def test_gate_time_scale_of_integrators_is_the_ramp_lag():
    """An integrator's time scale is how far its ramp lags an ideal integrator (T + delay,
    the intercept of the asymptote): the dead time is measured against it."""
    p = {"K": 0.5, "T": 4.0, "delay": 1.0}
    assert time_scale("integrator_lag", p) == 5.0
    assert time_scale("integrator", {"K": 0.5, "delay": 1.0}) == 1.0
    assert param_scale("delay", "integrator_lag", p) == 5.0
    assert relative_change("delay", "integrator_lag", p, 1.25) == pytest.approx(0.05)
    # a zero's change is measured on the model's time scale (it may sit near 0)
    z = {"K": 2.0, "Tz": 0.1, "T1": 8.0, "T2": 2.0}
    assert relative_change("Tz", "zero_two_lags", z, 0.6) == pytest.approx(0.05)


def test_step_response_distance_for_integrating_structures():
    a = {"K": 0.5, "T": 4.0, "delay": 1.0}
    # a ramp's distance is relative to its rise over the horizon: a 5 % gain change is 5 %
    assert step_response_distance("integrator_lag", a, "integrator_lag",
                                  {**a, "K": 0.525}) == pytest.approx(0.05, rel=0.02)
    # the pure integrator with the same asymptote (delay = T + L) is close at the horizon
    d = step_response_distance("integrator_lag", a, "integrator", {"K": 0.5, "delay": 5.0})
    assert 0 < d < 0.1
    assert step_response_distance("integrator_lag", a, "first_order",
                                  {"K": 0.5, "T": 4.0}) == math.inf
    z = {"K": 2.0, "Tz": -3.0, "T1": 8.0, "T2": 2.0}
    assert step_response_distance("zero_two_lags", z, "zero_two_lags", z) == 0.0
    assert step_response_distance("zero_two_lags", z, "two_lags",
                                  {"K": 2.0, "T1": 8.0, "T2": 2.0}) > 0.1


def test_history_has_a_column_per_parameter_and_tables_show_units():
    assert "Tz" in SCHEMA and SCHEMA["Tz"] == SCHEMA["T"]
    units = {"time": "s", "input": "V", "output": "cm"}
    text = params_text({"K": 0.5, "T": 4.0, "delay": 1.0}, units, "integrator_lag")
    assert text == "K=0.5 cm/V/s, T=4 s, delay=1 s"
    text = params_text({"K": 2.0, "Tz": -3.0, "T1": 8.0, "T2": 2.0}, units, "zero_two_lags")
    assert text == "K=2 cm/V, Tz=-3 s, T1=8 s, T2=2 s"
    assert params_text({"K": 2.0, "T": 5.0}) == "K=2, T=5"  # no units known: as before


@pytest.mark.parametrize("delay", [0.0, 2 * DT, 2.5 * DT])
def test_lead_lag_feedthrough_is_seen_at_the_step_sample(delay):
    """scipy's ZOH convention y[k] = C x[k] + D u[k]: the jump K Tz/T du appears at the
    sample where the (delayed) step arrives, on the lfilter and the pulse-response path
    alike (a fractional delay moves it to the next sample)."""
    m = ProcessModel("lead_lag", {"K": 2.0, "Tz": 6.0, "T": 3.0, "delay": delay})
    t = np.arange(40) * DT
    u = np.where(np.arange(40) >= 10, 2.0, 1.0)
    y = simulate(m, t, u, 1.0, 0.0)
    k = 10 + math.ceil(delay / DT - 1e-9)
    tau = t[k] - t[10] - delay
    assert y[k - 1] == 0.0
    assert y[k] == pytest.approx(2.0 + 2.0 * math.exp(-tau / 3.0))  # K (1 - (1 - Tz/T) e^..)
