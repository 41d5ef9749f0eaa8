"""Monte Carlo sets with known truth: the plants, noise colours and conditions the verdicts
and the recommendation are calibrated on, and the score of a recommendation against the
truth (DESIGN.md "Validation and grading": a right model on a well-posed record is "ok" in
at least 95 % of seeds; a wrong one is not "ok").

* :data:`PLANTS` - first order with dead time (delay/T 0.05 to 2), two lags, underdamped
  (zeta 0.15 and 0.6), equal-lag chains (3 and 6 lags), an integrator with lag, an
  inverse response and a lead-lag;
* :func:`noise` - white, AR(1) (phi :data:`AR1_PHI`) and 1/f noise of a given marginal
  standard deviation;
* :class:`Condition` - noise colour and level, the window between steps in units of the
  plant's :attr:`Plant.T` (a third of its 95 % settling time: a window of 3 T ends
  where the response is within 5 % of its final value, so the next step starts from a
  moving output), and a sample time;
* :func:`mc_record` - a staircase of steps from a nonzero operating point (the first from
  rest after a baseline, the others each from where the previous one had got to);
* :func:`score` - the recommended model's unit-step response against the truth's at the
  record's samples over one window (``error``: the largest difference over the truth's
  largest response), and whether it is the true structure or an exact
  re-parameterisation of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from ..models import ProcessModel
from ..record import Record, make_record
from .plants import response, staircase

#: Noise colours of the Monte Carlo sets.
NOISE_KINDS = ("white", "ar1", "pink")
#: AR(1) coefficient of the coloured noise (a correlation time of about ten samples).
AR1_PHI = 0.9
#: Input levels of the staircase: from u0 to each in turn.
U0, LEVELS = 2.0, (5.0, 3.0, 4.5, 2.5)
#: The output's operating point.
Y0 = 7.0
#: A step response within this share of the truth's is "right".
RIGHT_ERROR = 0.03


@dataclass(frozen=True)
class Plant:
    """A plant with known truth: its ``model`` and ``T``, a third of its 95 % settling
    time (the time after which its unit step stays within 5 % of the final value; for an
    integrator with lag, within 5 % of the final ramp's asymptote)."""

    name: str
    model: ProcessModel

    @property
    def T(self) -> float:
        return settling_time(self.model) / 3.0


def settling_time(model: ProcessModel, band: float = 0.05) -> float:
    """The time after which the unit step stays within ``band`` of its final value (an
    integrating model: of its final ramp's asymptote ``K (t - time_scale)``, relative to
    ``K time_scale``, and at least its dead time plus three lags)."""
    scale = max(model.time_scale, model.delay, 1e-9)
    t = np.linspace(0.0, 60.0 * scale, 60001)
    s = model.unit_step(t)
    if model.integrating:
        lag = max(model.time_scale, 1e-9)
        target = model.K * (t - lag)
        off = np.abs(s - target) > band * abs(model.K) * lag
    else:
        off = np.abs(s - model.K) > band * abs(model.K)
    k = np.flatnonzero(off)
    return float(t[min(k[-1] + 1, t.size - 1)]) if k.size else float(t[1])


def _m(structure: str, **p: float) -> ProcessModel:
    return ProcessModel(structure, p)


#: The plants of issue 27's sets (names say what they are).
PLANTS: dict[str, Plant] = {p.name: p for p in (
    Plant("fopdt_delay0.05", _m("first_order", K=2.0, T=10.0, delay=0.5)),
    Plant("fopdt_delay0.5", _m("first_order", K=2.0, T=10.0, delay=5.0)),
    Plant("fopdt_delay2", _m("first_order", K=-1.5, T=10.0, delay=20.0)),
    Plant("two_lags", _m("two_lags", K=1.5, T1=10.0, T2=3.0, delay=1.0)),
    Plant("underdamped_0.15", _m("second_order", K=0.8, zeta=0.15, wn=0.5, delay=0.0)),
    Plant("underdamped_0.6", _m("second_order", K=0.8, zeta=0.6, wn=0.5, delay=1.0)),
    Plant("lags_3", _m("n_lags", K=1.2, T=4.0, n=3.0, delay=0.0)),
    Plant("lags_6", _m("n_lags", K=1.2, T=2.0, n=6.0, delay=1.0)),
    Plant("integrator_lag", _m("integrator_lag", K=0.05, T=5.0, delay=1.0)),
    Plant("inverse_response", _m("zero_two_lags", K=1.0, Tz=-4.0, T1=10.0, T2=5.0, delay=0.0)),
    Plant("lead_lag", _m("lead_lag", K=1.0, Tz=15.0, T=8.0, delay=0.5)),
    Plant("zero_two_lags", _m("zero_two_lags", K=2.0, Tz=6.0, T1=12.0, T2=3.0, delay=0.5)),
    Plant("first_order_fast", _m("first_order", K=0.7, T=2.0, delay=0.2)),
    Plant("two_lags_equal", _m("two_lags", K=1.0, T1=6.0, T2=6.0, delay=2.0)),
)}


@dataclass(frozen=True)
class Condition:
    """How a Monte Carlo record is logged: noise ``kind`` and ``level`` (its standard
    deviation over the output's change ``|K| du`` of the first step; for an integrator
    over its change across one window), the ``window`` between steps in units of the
    plant's ``T``, and ``samples_per_T`` samples per T."""

    kind: str = "white"
    level: float = 0.01
    window: float = 4.0
    samples_per_T: int = 50

    @property
    def label(self) -> str:
        return f"{self.kind} {self.level:.1%} window {self.window:g}T"


def noise(kind: str, n: int, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """``n`` samples of zero-mean noise of marginal standard deviation ``sigma``: white,
    AR(1) with :data:`AR1_PHI` (started in its stationary distribution), or 1/f
    (``pink``: white noise shaped by ``1/sqrt(f)`` in the frequency domain, so its power
    falls as 1/f down to the record's length; scaled to ``sigma`` over the record)."""
    if kind == "white":
        return rng.normal(0.0, sigma, n)
    if kind == "ar1":
        return ar1_noise(n, sigma, AR1_PHI, rng)
    if kind == "pink":
        f = np.fft.rfftfreq(n)
        spec = rng.normal(size=f.size) + 1j * rng.normal(size=f.size)
        spec[1:] /= np.sqrt(f[1:])
        spec[0] = 0.0
        x = np.fft.irfft(spec, n)
        return x * (sigma / float(np.std(x)))
    raise ValueError(f"unknown noise kind {kind!r}; expected one of {NOISE_KINDS}")


def ar1_noise(n: int, sigma: float, phi: float, rng: np.random.Generator) -> np.ndarray:
    """``n`` samples of AR(1) noise ``v[k] = phi v[k-1] + w[k]`` of marginal standard
    deviation ``sigma``, started in its stationary distribution."""
    e = rng.normal(0.0, sigma * math.sqrt(1.0 - phi**2), n)
    x0 = rng.normal(0.0, sigma)
    return lfilter([1.0], [1.0, -phi], e, zi=[phi * x0])[0]


def mc_record(plant: Plant, condition: Condition, seed: int) -> Record:
    """A staircase record of ``plant`` under ``condition`` (see the module docstring): a
    baseline of one window at ``U0``, then a step to each of :data:`LEVELS` every window,
    each window ``condition.window`` T long, with the noise of ``condition`` and ``seed``.
    An integrating plant's output ramps during each window; its levels alternate around
    the operating point so it stays bounded."""
    T, w = plant.T, condition.window * plant.T
    dt = T / condition.samples_per_T
    n_windows = 1 + len(LEVELS)
    t = np.arange(int(round(n_windows * w / dt)) + 1) * dt
    levels = LEVELS if not plant.model.integrating else (3.0, 1.0, 3.0, 1.0)
    u = staircase(t, U0, [((k + 1) * w, v) for k, v in enumerate(levels)])
    y = response(plant.model, t, u, U0, Y0)
    du = abs(levels[0] - U0)
    change = abs(plant.model.K) * du * (w if plant.model.integrating else 1.0)
    rng = np.random.default_rng(seed)
    y = y + noise(condition.kind, t.size, condition.level * change, rng)
    return make_record(t, u, y, name=f"{plant.name} {condition.label} seed {seed}",
                       source=f"<monte carlo {plant.name}>")


@dataclass(frozen=True)
class Score:
    """A model against the truth: the largest unit-step difference over the window
    relative to the truth's largest response (``error``), and whether its structure is
    the truth's or an exact re-parameterisation of it (``structure``)."""

    error: float
    structure: bool

    @property
    def right(self) -> bool:
        return self.error <= RIGHT_ERROR


def score(model: ProcessModel, plant: Plant, condition: Condition) -> Score:
    """``model`` against ``plant``'s truth over one window (see :class:`Score`)."""
    truth = plant.model
    dt = plant.T / condition.samples_per_T  # as sampled: a jump is seen where it is logged
    t = np.arange(0.0, condition.window * plant.T + dt / 2, dt)
    s_true, s = truth.unit_step(t), model.unit_step(t)
    err = float(np.max(np.abs(s - s_true)) / max(float(np.max(np.abs(s_true))), 1e-300))
    return Score(err, same_structure(model, truth))


def same_structure(model: ProcessModel, truth: ProcessModel) -> bool:
    """Whether ``model`` has the truth's structure or is an exact re-parameterisation of
    it: two real lags as an overdamped second order or an equal-lag pair, one lag as a
    chain of one, an equal-lag chain of n as two lags when n is 2."""
    if model.structure == truth.structure:
        return (truth.structure != "n_lags"
                or float(model.params["n"]) == float(truth.params["n"]))
    lags_m, lags_t = model.lags(), truth.lags()
    if model.integrating or truth.integrating:
        return False
    return bool(lags_t) and len(lags_m) == len(lags_t) and "Tz" not in model.params \
        and "Tz" not in truth.params
