"""Åström & Hägglund's PID benchmark plants, logged as a noisy step test, identified and
tuned, and the settings checked on the TRUE plant (issue 28): shared by
``tests/test_tuning_e2e.py`` (a few fixed seeds) and ``benchmarks/tuning_e2e.py`` (the
Monte Carlo).

The plant families are those of K. J. Åström and T. Hägglund, "Benchmark systems for PID
control", IFAC Workshop on Digital Control: Past, Present and Future of PID Control
(PID'00), Terrassa, 2000 (also the test batch of their *Advanced PID Control*, ISA 2006,
Section 7.2):

- P1 multiple equal poles ``1/(s+1)^n``;
- P2 fourth order with spread lags ``1/((1+s)(1+a s)(1+a^2 s)(1+a^3 s))``;
- P3 a right-half-plane zero ``(1-a s)/(s+1)^3``;
- P4 dead time and lag ``e^(-L s)/(1+s T)``;
- P5 dead time and double lag ``e^(-L s)/(1+s T)^2``;
- P6 fast and slow modes ``100/(s+10)^2 (1/(s+1) + 0.5/(s+0.05))``;
- P7 oscillatory ``w0^2/((s+1)(s^2+2 zeta w0 s+w0^2))`` (zeta 0.1).

:data:`PLANTS` holds one or two members per family, each with the sampling period of its
log (a tenth or less of its dominant time constant; a delay is a whole number of samples,
so the zero-order-hold simulation is exact). :func:`step_test` logs a test as an engineer
would: a nonzero operating point, the input stepping up at a seed-dependent time after a
baseline, back down once the output has settled, the record ending when it has settled
again, with 1 % (of the output change) white or AR(1) noise (phi :data:`AR1_PHI`, the same
marginal standard deviation). :func:`run_case` identifies it with :func:`pipeline.identify`,
takes the SIMC tuning of the recommended model (the default rule) and evaluates those
settings on the true plant: Nyquist stability and Ms with the exact dead time
(:func:`pipeline.tuning.loop_margins` on ``C(jw) P_true(jw)``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import signal

import pipeline
from pipeline.tuning import FRAGILE_MS, loop_margins
from pipeline.tuning.controller import Controller

#: Noise kinds of the step tests, their level (share of the output change) and AR(1)'s phi.
NOISE_KINDS = ("white", "ar1")
NOISE_LEVEL = 0.01
AR1_PHI = 0.8
#: The operating point (input, output) and the test's input step.
U0, Y0, DU = 2.0, 10.0, 1.5
#: The claims checked on the true plant: Ms at most this in at least this share of seeds.
MS_LIMIT = FRAGILE_MS
MS_SHARE = 0.95


@dataclass(frozen=True)
class BenchmarkPlant:
    """A true plant ``num(s)/den(s) e^(-delay s)`` (descending powers) and its log's
    sampling period ``dt`` (s)."""

    name: str
    family: str
    formula: str
    num: tuple[float, ...]
    den: tuple[float, ...]
    dt: float
    delay: float = 0.0

    def __post_init__(self) -> None:
        k = self.delay / self.dt
        if abs(k - round(k)) > 1e-9:
            raise ValueError(f"{self.name}: the delay must be a whole number of samples")

    @property
    def gain(self) -> float:
        return float(self.num[-1] / self.den[-1])

    @cached_property
    def poles(self) -> np.ndarray:
        return np.roots(self.den)

    @property
    def time_scale(self) -> float:
        """The sum of the time constants ``1/|p|`` over the poles, plus the dead time (the
        characteristic time :func:`~pipeline.tuning.loop_margins` sets its grid from)."""
        return float(np.sum(1.0 / np.abs(self.poles))) + self.delay

    def response(self, s: np.ndarray) -> np.ndarray:
        """``P(s)`` with its exact dead time."""
        s = np.asarray(s, dtype=np.complex128)
        return (np.polyval(self.num, s) / np.polyval(self.den, s)) * np.exp(-self.delay * s)

    @cached_property
    def _discrete(self):
        a, b, c, d = signal.tf2ss(np.asarray(self.num, float), np.asarray(self.den, float))
        ad, bd, cd, dd, _ = signal.cont2discrete((a, b, c, d), self.dt, method="zoh")
        return ad, bd.ravel(), cd.ravel(), float(np.ravel(dd)[0])

    def simulate(self, du: np.ndarray) -> np.ndarray:
        """The exact output deviation at the samples for a zero-order-hold input deviation
        ``du`` (from rest), the dead time a shift by whole samples."""
        ad, bd, cd, dd = self._discrete
        nd = int(round(self.delay / self.dt))
        ud = np.concatenate([np.zeros(nd), du[:du.size - nd]]) if nd else du
        x = np.zeros(ad.shape[0])
        y = np.empty(ud.size)
        for k, v in enumerate(ud):
            y[k] = cd @ x + dd * v
            x = ad @ x + bd * v
        return y

    @cached_property
    def settling_time(self) -> float:
        """The time after which the unit step stays within 2 % of its final value."""
        t_end = 60.0 * self.time_scale
        n = int(math.ceil(t_end / self.dt))
        y = self.simulate(np.ones(n + 1))
        off = np.flatnonzero(np.abs(y - self.gain) > 0.02 * abs(self.gain))
        return float((off[-1] + 1) * self.dt) if off.size else self.dt

    @property
    def window(self) -> float:
        """The time between the steps (and after the last one): 1.5 settling times, whole
        samples."""
        return self.dt * math.ceil(1.5 * self.settling_time / self.dt)


def _p(name, family, formula, num, den, dt, delay=0.0) -> BenchmarkPlant:
    return BenchmarkPlant(name, family, formula, tuple(float(x) for x in num),
                          tuple(float(x) for x in den), dt, delay)


def _lags(*taus: float) -> np.ndarray:
    out = np.array([1.0])
    for tau in taus:
        out = np.polymul(out, [tau, 1.0])
    return out


def _fast_slow() -> tuple[np.ndarray, np.ndarray]:
    # 100/(s+10)^2 (1/(s+1) + 0.5/(s+0.05)) = 100 (1.5 s + 0.55)/((s+10)^2 (s+1)(s+0.05))
    den = np.polymul(np.polymul([1.0, 20.0, 100.0], [1.0, 1.0]), [1.0, 0.05])
    return 100.0 * np.array([1.5, 0.55]), den


def _oscillatory(w0: float, zeta: float) -> tuple[np.ndarray, np.ndarray]:
    return np.array([w0 * w0]), np.polymul([1.0, 1.0], [1.0, 2.0 * zeta * w0, w0 * w0])


#: The plants (name -> plant): one or two members per family, parameters in the names.
PLANTS: dict[str, BenchmarkPlant] = {p.name: p for p in (
    _p("P1 n=4", "P1", "1/(s+1)^4", [1.0], _lags(*[1.0] * 4), 0.05),
    _p("P1 n=8", "P1", "1/(s+1)^8", [1.0], _lags(*[1.0] * 8), 0.1),
    _p("P2 a=0.5", "P2", "1/((1+s)(1+0.5s)(1+0.25s)(1+0.125s))", [1.0],
       _lags(1.0, 0.5, 0.25, 0.125), 0.02),
    _p("P2 a=0.2", "P2", "1/((1+s)(1+0.2s)(1+0.04s)(1+0.008s))", [1.0],
       _lags(1.0, 0.2, 0.04, 0.008), 0.01),
    _p("P3 a=0.5", "P3", "(1-0.5s)/(s+1)^3", [-0.5, 1.0], _lags(1.0, 1.0, 1.0), 0.05),
    _p("P3 a=2", "P3", "(1-2s)/(s+1)^3", [-2.0, 1.0], _lags(1.0, 1.0, 1.0), 0.05),
    _p("P4 L=1 T=1", "P4", "e^(-s)/(1+s)", [1.0], _lags(1.0), 0.05, 1.0),
    _p("P4 L=1 T=10", "P4", "e^(-s)/(1+10s)", [1.0], _lags(10.0), 0.1, 1.0),
    _p("P5 L=1 T=1", "P5", "e^(-s)/(1+s)^2", [1.0], _lags(1.0, 1.0), 0.05, 1.0),
    _p("P5 L=1 T=5", "P5", "e^(-s)/(1+5s)^2", [1.0], _lags(5.0, 5.0), 0.1, 1.0),
    _p("P6", "P6", "100/(s+10)^2 (1/(s+1)+0.5/(s+0.05))", *_fast_slow(), 0.05),
    _p("P7 w0=1 zeta=0.1", "P7", "1/((s+1)(s^2+0.2s+1))", *_oscillatory(1.0, 0.1), 0.05),
    _p("P7 w0=3 zeta=0.1", "P7", "9/((s+1)(s^2+0.6s+9))", *_oscillatory(3.0, 0.1), 0.02),
)}

#: The member of each family the unit test runs (the benchmark runs them all).
TEST_PLANTS = ("P1 n=4", "P2 a=0.5", "P3 a=0.5", "P4 L=1 T=1", "P5 L=1 T=1", "P6",
               "P7 w0=3 zeta=0.1")
#: The P4 member whose bare identification is the benchmark's time unit.
BASELINE_PLANT = "P4 L=1 T=1"


def noise(kind: str, n: int, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """White noise, or AR(1) with :data:`AR1_PHI` started in its stationary distribution;
    marginal standard deviation ``sigma`` either way."""
    if kind == "white":
        return rng.normal(0.0, sigma, n)
    if kind == "ar1":
        e = rng.normal(0.0, sigma * math.sqrt(1.0 - AR1_PHI**2), n)
        x0 = rng.normal(0.0, sigma)
        return signal.lfilter([1.0], [1.0, -AR1_PHI], e, zi=[AR1_PHI * x0])[0]
    raise ValueError(f"unknown noise kind {kind!r}; one of {NOISE_KINDS}")


def step_test(plant: BenchmarkPlant, kind: str, seed: int
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t, u, y)`` of a logged step test: the input at :data:`U0` for a baseline of 0.2 to
    0.5 windows (the seed draws it, whole samples), up by :data:`DU`, back down one window
    later, the record ending one window after that; the output around :data:`Y0` with
    :data:`NOISE_LEVEL` x ``|K DU|`` noise of ``kind``."""
    rng = np.random.default_rng(seed)
    w, dt = plant.window, plant.dt
    t_up = dt * round((0.2 + 0.3 * rng.random()) * w / dt)
    t_down = t_up + w
    n = int(round((t_down + w) / dt)) + 1
    t = np.arange(n) * dt
    du = np.where((t >= t_up - 1e-9 * dt) & (t < t_down - 1e-9 * dt), DU, 0.0)
    y = Y0 + plant.simulate(du)
    y = y + noise(kind, n, NOISE_LEVEL * abs(plant.gain * DU), rng)
    return t, U0 + du, y


def true_margins(plant: BenchmarkPlant, controller: Controller):
    """The controller on the true plant: :class:`~pipeline.tuning.Margins` of
    ``C(s) P_true(s)`` with the exact dead time (Nyquist stability, Ms); the benchmark
    plants have no pole in the right half plane."""
    return loop_margins(lambda s: controller.response(s) * plant.response(s),
                        delay=plant.delay, time_scale=plant.time_scale,
                        origin_poles=int(controller.integrating), rhp_poles=0)


def run_case(plant_name: str, kind: str, seed: int) -> dict:
    """One step test identified, tuned (SIMC on the recommended model) and checked on the
    true plant: a row of plain values (the model, its verdict, the controller, the
    tuning's verdict and nominal / worst-case Ms, the true stability and Ms, seconds;
    ``smooth_flags``: the flags of the first-order refinement on the same event)."""
    plant = PLANTS[plant_name]
    t, u, y = step_test(plant, kind, seed)
    t0 = time.perf_counter()
    res = pipeline.identify(t, u, y)
    seconds = time.perf_counter() - t0
    row: dict = {"plant": plant_name, "family": plant.family, "kind": kind, "seed": seed,
                 "seconds": seconds, "samples": int(t.size), "error": res.error}
    fit = res.recommended
    if fit is not None and fit.model is not None:
        row.update(method=fit.method, structure=fit.model.structure,
                   params={k: float(v) for k, v in fit.model.params.items()},
                   model_verdict=fit.verdict,
                   flags=[f.code for f in (*fit.flags, *res.flags)])
        smooth = res.fit("lsq_first_order", fit.event, ())
        row["smooth_flags"] = [f.code for f in smooth.flags] if smooth is not None else []
    rt = res.tuning
    tu = rt.tuning if rt is not None else None
    if tu is None:
        row.update(verdict=None, reason=rt.reason if rt is not None else "no model")
        return row
    c = tu.controller
    m = true_margins(plant, c)
    row.update(verdict=tu.verdict, reasons=list(tu.reasons),
               controller={"kind": c.kind, "Kc": c.Kc, "Ti": c.Ti, "Td": c.Td, "Tf": c.Tf},
               model_ms=float(tu.margins.ms),
               worst_ms=float(tu.worst.ms) if tu.worst is not None else None,
               true_stable=bool(m.stable), true_ms=float(m.ms) if m.stable else math.inf,
               true_gm=float(m.gain_margin), true_pm=float(m.phase_margin))
    return row


def claims(rows: list[dict]) -> dict[str, object]:
    """The issue's three claims over ``rows`` (every row must have a tuning): the share of
    stable loops (claim: 1), the share with true Ms <= :data:`MS_LIMIT` (claim: >=
    :data:`MS_SHARE`), and the rows called "robust" whose true Ms exceeds the limit
    (claim: none)."""
    n = len(rows)
    return {"n": n, "untuned": [r for r in rows if r.get("verdict") is None],
            "stable": sum(1 for r in rows if r.get("true_stable")) / n if n else math.nan,
            "ms_ok": sum(1 for r in rows if r.get("true_ms", math.inf) <= MS_LIMIT) / n
            if n else math.nan,
            "robust_above": [r for r in rows if r.get("verdict") == "robust"
                             and r.get("true_ms", math.inf) > MS_LIMIT]}
