"""IAE-optimal PI control of a first-order-plus-dead-time process at a given Ms, and how
close a tuning rule comes to it (issue 28, "near-optimal"): shared by
``tests/test_tuning_optimal.py`` (a subset of the plants) and
``benchmarks/tuning_optimal.py`` (the whole sweep).

The comparison is that of C. Grimholt and S. Skogestad, "Optimal PI-control and
verification of the SIMC tuning rule", IFAC Conference on Advances in PID Control (PID'12),
Brescia, 2012 (and, for the same cost, their "Optimal PI and PID control of first-order
plus delay processes and evaluation of the original and improved SIMC rules", *J. Process
Control* 70 (2018) 36-46). On ``P(s) = K e^(-theta s)/(tau s + 1)`` with the PI controller
``C(s) = Kc (1 + 1/(Ti s))`` acting on ``e = r - y``:

- ``IAE_dy``: ``int |e| dt`` after a unit step added to the output (with no setpoint
  weight, the same ``|e|`` as a unit setpoint step); ``IAE_du``: after a unit step added
  to the plant input;
- the cost ``J = 0.5 (IAE_dy/IAE_dy° + IAE_du/IAE_du°)`` (their eq. (3)), where the
  weights ``IAE_dy°`` and ``IAE_du°`` are the IAEs of the IAE-optimal PI controllers for
  each disturbance alone, both reference controllers constrained to ``Ms = 1.59``
  (:data:`REFERENCE_MS`, SIMC's value with ``tau_c = theta`` for ``tau <= 8 theta``): the
  weights are fixed for a process, the same for every controller compared on it;
- the optimal trade-off ``J_opt(Ms)``: the least ``J`` over PI controllers with that
  ``Ms``; a rule is judged by ``J_rule/J_opt(Ms_rule)``, the optimum taken at the rule's
  own ``Ms``.

:func:`compare` also gives the variant that normalises by the single-disturbance optima at
the rule's own ``Ms`` (``reference_ms=None``), for information.

Everything here is computed by the project's own means where it has them: the rules'
settings by :func:`pipeline.tuning.tune_rule`, Ms with the exact dead time and Nyquist
stability by :func:`pipeline.tuning.loop_margins`. The IAEs come from an exact-delay
simulation of the loop by the method of steps (:func:`iae`): over each stretch of one dead
time the plant input is the controller output of the stretch before, so the plant (exact
first-order-hold discretisation) and the controller (trapezoidal integral) are vectorised
over ``n`` samples per dead time; the error is second order in ``theta/n`` (``n = 200``:
a relative error about 3e-7, checked against the closed forms in the test). The optimiser
(:func:`optimal_pi`) runs along the curve ``Ms(Kc, Ti) = Ms_target``: for each ``Ti`` the
gain that meets the target (``scipy.optimize.brentq`` on ``log Kc``), and over ``log Ti`` a
coarse scan, then ``scipy.optimize.minimize_scalar`` (bounded) in the best bracket.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq, minimize, minimize_scalar
from scipy.signal import lfilter

from pipeline.models import ProcessModel
from pipeline.tuning import loop_margins, tune_rule

#: The Ms of the two reference controllers that normalise J (Grimholt & Skogestad 2012).
REFERENCE_MS = 1.59
#: The issue's bounds: SIMC PI (tau_c = theta) within 15 % of the optimum for
#: tau/theta >= 1; improved SIMC PI within 5 % on a delay-dominant process.
SIMC_BOUND = 1.15
IMPROVED_BOUND = 1.05
#: tau/theta of the FOPDT sweep (the issue's), the range the SIMC bound is claimed on, and
#: the delay-dominant plant of the improved-SIMC claim.
RATIOS = (0.1, 0.5, 1.0, 2.0, 4.0, 8.0, 20.0)
SIMC_CLAIMED_FROM = 1.0
DELAY_DOMINANT = 0.1
#: Samples per dead time of the IAE simulation.
SAMPLES_PER_DELAY = 200
#: |e| beyond this (after a unit step) marks an unstable loop.
DIVERGED = 1e6


@dataclass(frozen=True)
class Fopdt:
    """``K e^(-theta s)/(tau s + 1)``."""

    K: float
    tau: float
    theta: float

    @classmethod
    def ratio(cls, tau_over_theta: float, K: float = 1.0, theta: float = 1.0) -> Fopdt:
        return cls(K, tau_over_theta * theta, theta)

    @property
    def model(self) -> ProcessModel:
        return ProcessModel("first_order", {"K": self.K, "T": self.tau, "delay": self.theta})

    def response(self, s: np.ndarray) -> np.ndarray:
        return self.K * np.exp(-self.theta * s) / (self.tau * s + 1.0)


def ms(plant: Fopdt, kc: float, ti: float) -> float:
    """Ms of the PI loop with the exact dead time (:func:`pipeline.tuning.loop_margins`);
    ``inf`` when the closed loop is unstable."""

    def loop(s: np.ndarray) -> np.ndarray:
        return kc * (1.0 + 1.0 / (ti * s)) * plant.response(s)

    m = loop_margins(loop, delay=plant.theta, time_scale=plant.tau + plant.theta,
                     origin_poles=1)
    return m.ms if m.stable else math.inf


def _block_iae(e: np.ndarray, h: float) -> np.ndarray:
    """Per row, ``int |e|`` of the samples ``e`` (rows, n + 1) linear between samples (a
    sign change inside an interval integrated exactly for the linear interpolant)."""
    a, c = e[:, :-1], e[:, 1:]
    seg = np.abs(a) + np.abs(c)
    cross = a * c < 0
    if cross.any():
        aa, cc = a[cross], c[cross]
        seg[cross] = (aa * aa + cc * cc) / (np.abs(aa) + np.abs(cc))
    return 0.5 * h * seg.sum(axis=1)


def iae(plant: Fopdt, kc: float, ti: float, n: int = SAMPLES_PER_DELAY, tol: float = 1e-10,
        max_delays: int = 20_000) -> tuple[float, float]:
    """``(IAE_dy, IAE_du)`` of the PI loop after a unit output and a unit input step at
    ``t = 0`` (both at once, one row each), by the method of steps (module docstring).

    Stretch ``b`` covers ``[b theta, (b + 1) theta]`` with ``n + 1`` samples (the ends
    shared with its neighbours); the plant input on it is the previous stretch's
    controller output plus the input disturbance, linear between samples, and the first
    stretch's is zero (the disturbance and the controller's jump at ``t = 0+`` reach the
    plant one dead time later). The run stops when a stretch adds less than ``tol`` of the
    IAE so far and the plant input has settled; it returns ``inf`` once ``|e|`` passes
    :data:`DIVERGED` (an unstable loop). ``theta = 0`` goes to
    :func:`_iae_delay_free` (exact).
    """
    if plant.theta <= 0:
        return _iae_delay_free(plant, kc, ti, 10 * n)
    K, tau, h = plant.K, plant.tau, plant.theta / n
    dy = np.array([[1.0], [0.0]])
    du = np.array([[0.0], [1.0]])
    if tau > 0:  # exact first-order hold: x' = (K w - x)/tau with w linear on each step
        phi = math.exp(-h / tau)
        q = (tau / h) * -math.expm1(-h / tau)
        g1, g0 = K * (1.0 - q), K * (q - phi)
    w = np.zeros((2, n + 1))  # the plant input on the current stretch
    x0 = np.zeros((2, 1))
    z0 = np.zeros((2, 1))
    total = np.zeros(2)
    for _ in range(max_delays):
        if tau > 0:
            v = g0 * w[:, :-1] + g1 * w[:, 1:]
            xs, _zf = lfilter([1.0], [1.0, -phi], v, axis=1, zi=phi * x0)
            x = np.concatenate([x0, xs], axis=1)
        else:
            x = K * w
        e = -(x + dy)
        z = z0 + np.concatenate([np.zeros((2, 1)),
                                 np.cumsum(0.5 * h * (e[:, :-1] + e[:, 1:]), axis=1)], axis=1)
        u = kc * (e + z / ti)
        part = _block_iae(e, h)
        total += part
        if not np.all(np.abs(e[:, -1]) < DIVERGED):  # an unstable loop: no finite IAE
            return math.inf, math.inf
        w_new = u + du
        settled = np.abs(w_new[:, -1] - w_new[:, 0]) <= tol * (1.0 + np.abs(w_new[:, -1]))
        if np.all((part <= tol * total) & settled):
            break
        w, x0, z0 = w_new, x[:, -1:], z[:, -1:]
    else:
        raise RuntimeError(f"the loop Kc={kc:g}, Ti={ti:g} did not settle in "
                           f"{max_delays} dead times")
    return float(total[0]), float(total[1])


def _iae_delay_free(plant: Fopdt, kc: float, ti: float, n: int) -> tuple[float, float]:
    """``theta = 0``: the loop is a linear ODE in (plant state, integral of e) driven by
    constant steps, sampled exactly (matrix exponential) at ``h = tau/n`` (the time scale
    is ``tau`` or the closed loop's slowest pole, whichever is longer)."""
    K, tau = plant.K, plant.tau
    # x' = (K (u + du) - x)/tau, u = Kc (e + z/Ti), e = -(x + dy), z' = e
    a = np.array([[(-1.0 - K * kc) / tau, K * kc / (ti * tau)], [-1.0, 0.0]])
    slow = 1.0 / np.min(np.abs(np.linalg.eigvals(a).real))
    h = min(tau, slow) / n
    out = []
    for dy, du in ((1.0, 0.0), (0.0, 1.0)):
        b = np.array([(K * du - K * kc * dy) / tau, -dy])
        m = np.zeros((3, 3))
        m[:2, :2], m[:2, 2] = a, b
        step = expm(m * h)
        steps = int(math.ceil(40.0 * slow / h)) + 1
        s = np.zeros((steps + 1, 3))
        s[0, 2] = 1.0
        for k in range(steps):
            s[k + 1] = step @ s[k]
        e = -(s[:, 0] + dy)
        out.append(float(_block_iae(e[None, :], h)[0]))
    return out[0], out[1]


@dataclass(frozen=True)
class OptimalPi:
    """The least ``cost = w_dy IAE_dy + w_du IAE_du`` over PI controllers with ``Ms =
    ms_target``: the settings, their Ms and IAEs, the cost, the evaluations it took
    (loop_margins calls, IAE simulations), whether the Ms bound is active (a little more
    gain at the optimum would lower the cost: the optimum of ``Ms <= ms_target`` is on the
    curve) and the seconds it took."""

    kc: float
    ti: float
    ms: float
    iae_dy: float
    iae_du: float
    cost: float
    weights: tuple[float, float]
    ms_target: float
    n_ms: int
    n_iae: int
    active: bool
    seconds: float


class _Curve:
    """The constraint curve ``Ms(Kc, Ti) = target`` and the cost along it, memoised."""

    def __init__(self, plant: Fopdt, target: float, weights: tuple[float, float],
                 kc_guess: float) -> None:
        self.plant, self.target, self.weights = plant, target, weights
        self.kc_guess = kc_guess
        self.n_ms = self.n_iae = 0
        self.points: dict[float, tuple[float, float, float, float]] = {}

    def _ms_excess(self, log_kc: float, ti: float) -> float:
        self.n_ms += 1
        return ms(self.plant, math.exp(log_kc), ti) - self.target

    def kc_at(self, ti: float) -> float:
        """The gain with Ms = target at this Ti (Ms grows with the gain)."""
        lo = hi = math.log(self.kc_guess)
        f_lo = f_hi = self._ms_excess(lo, ti)
        step = 0.25
        while f_lo > 0:
            hi, f_hi = lo, f_lo
            lo -= step
            step *= 2
            f_lo = self._ms_excess(lo, ti)
        step = 0.25
        while f_hi <= 0:
            lo, f_lo = hi, f_hi
            hi += step
            step *= 2
            f_hi = self._ms_excess(hi, ti)
            if hi - lo > 40:
                raise RuntimeError(f"Ms never reaches {self.target} at Ti={ti:g}")
        # shrink an unstable (or far) upper end first: brentq needs finite values
        while math.isinf(f_hi) or f_hi > 1.0:
            mid = 0.5 * (lo + hi)
            f_mid = self._ms_excess(mid, ti)
            if f_mid > 0:
                hi, f_hi = mid, f_mid
            else:
                lo, f_lo = mid, f_mid
        log_kc = brentq(lambda v: self._ms_excess(v, ti), lo, hi, xtol=1e-12, rtol=1e-12)
        kc = math.exp(log_kc)
        self.kc_guess = kc
        return kc

    def at(self, log_ti: float) -> float:
        if log_ti not in self.points:
            ti = math.exp(log_ti)
            kc = self.kc_at(ti)
            dy, du = iae(self.plant, kc, ti)
            self.n_iae += 1
            cost = self.weights[0] * dy + self.weights[1] * du
            self.points[log_ti] = (kc, dy, du, cost)
        return self.points[log_ti][3]


def optimal_pi(plant: Fopdt, ms_target: float, weights: tuple[float, float],
               ti_start: float, kc_start: float, half_width: float = 1.2,
               n_scan: int = 7) -> OptimalPi:
    """The IAE-optimal PI (module docstring) for ``weights`` ``(w_dy, w_du)`` at
    ``ms_target``, warm-started from ``(kc_start, ti_start)`` (a rule's settings): a
    scan of ``n_scan`` points over ``log Ti`` within ``half_width`` of the start (widened
    while the best point is at an end), then bounded Brent between the best point's
    neighbours."""
    t0 = time.perf_counter()
    curve = _Curve(plant, ms_target, weights, kc_start)
    centre = math.log(ti_start)
    lo, hi = centre - half_width, centre + half_width
    grid = list(np.linspace(lo, hi, n_scan))
    # the scan from the start outwards, so that each root-find starts next to the last
    order = sorted(range(n_scan), key=lambda i: abs(grid[i] - centre))
    for i in order:
        curve.at(grid[i])
    for _ in range(20):  # widen while the best point is at an end
        best = min(range(len(grid)), key=lambda i: curve.at(grid[i]))
        if 0 < best < len(grid) - 1:
            break
        d = grid[1] - grid[0]
        if best == 0:
            curve.kc_guess = curve.points[grid[0]][0]
            grid.insert(0, grid[0] - d)
            curve.at(grid[0])
        else:
            curve.kc_guess = curve.points[grid[-1]][0]
            grid.append(grid[-1] + d)
            curve.at(grid[-1])
    else:
        raise RuntimeError("the optimum along the Ms curve is not bracketed")
    curve.kc_guess = curve.points[grid[best]][0]
    minimize_scalar(curve.at, bounds=(grid[best - 1], grid[best + 1]), method="bounded",
                    options={"xatol": 1e-6})
    log_ti = min(curve.points, key=lambda k: curve.points[k][3])
    kc, dy, du, cost = curve.points[log_ti]
    ti = math.exp(log_ti)
    # is the bound active? 0.1 % more gain at the same Ti raises Ms; it must lower the cost
    dy2, du2 = iae(plant, kc * 1.001, ti)
    active = weights[0] * dy2 + weights[1] * du2 < cost
    return OptimalPi(kc=kc, ti=ti, ms=ms(plant, kc, ti), iae_dy=dy, iae_du=du, cost=cost,
                     weights=weights, ms_target=ms_target, n_ms=curve.n_ms + 1,
                     n_iae=curve.n_iae + 1, active=bool(active),
                     seconds=time.perf_counter() - t0)


@dataclass(frozen=True)
class Comparison:
    """A rule's PI settings on ``plant`` against the optimum at the same Ms: the rule's
    Ms and IAEs, the two reference optima that normalise J (at ``reference_ms``, or at the
    rule's own Ms when that is None), the optimum of J at the rule's Ms, and the ratio."""

    plant: Fopdt
    rule: str
    kc: float
    ti: float
    ms: float
    iae_dy: float
    iae_du: float
    ref_dy: OptimalPi
    ref_du: OptimalPi
    optimum: OptimalPi
    reference_ms: float | None
    seconds: float = field(default=0.0)

    @property
    def j(self) -> float:
        return 0.5 * (self.iae_dy / self.ref_dy.iae_dy + self.iae_du / self.ref_du.iae_du)

    @property
    def j_opt(self) -> float:
        return self.optimum.cost

    @property
    def ratio(self) -> float:
        return self.j / self.j_opt


def rule_pi(plant: Fopdt, rule: str) -> tuple[float, float]:
    """``(Kc, Ti)`` of the rule's PI (``tau_c`` its default: theta for SIMC)."""
    c = tune_rule(plant.model, rule, "PI").controller
    return c.Kc, c.Ti


def compare(plant: Fopdt, rule: str, reference_ms: float | None = REFERENCE_MS
            ) -> Comparison:
    """``rule``'s PI on ``plant`` against the optimal PI at the rule's Ms (module
    docstring); the optimisers start from the rule's settings."""
    t0 = time.perf_counter()
    kc, ti = rule_pi(plant, rule)
    m = ms(plant, kc, ti)
    dy, du = iae(plant, kc, ti)
    at = m if reference_ms is None else reference_ms
    ref_dy = optimal_pi(plant, at, (1.0, 0.0), ti, kc)
    ref_du = optimal_pi(plant, at, (0.0, 1.0), ti, kc)
    weights = (0.5 / ref_dy.iae_dy, 0.5 / ref_du.iae_du)
    opt = optimal_pi(plant, m, weights, ti, kc)
    return Comparison(plant=plant, rule=rule, kc=kc, ti=ti, ms=m, iae_dy=dy, iae_du=du,
                      ref_dy=ref_dy, ref_du=ref_du, optimum=opt, reference_ms=reference_ms,
                      seconds=time.perf_counter() - t0)


def slsqp_optimum(plant: Fopdt, ms_target: float, weights: tuple[float, float],
                  kc_start: float, ti_start: float) -> OptimalPi:
    """A cross-check of :func:`optimal_pi` by another route: ``scipy.optimize.minimize``
    (SLSQP) over ``(log Kc, log Ti)`` with the inequality ``Ms <= ms_target``, from
    ``(kc_start, ti_start)`` (finite-difference gradients)."""
    t0 = time.perf_counter()
    count = {"ms": 0, "iae": 0}

    def cost(x: np.ndarray) -> float:
        if not ms(plant, math.exp(x[0]), math.exp(x[1])) < 2 * ms_target:
            return 1e6  # far outside the bound (or unstable): slow to settle, not simulated
        count["iae"] += 1
        dy, du = iae(plant, math.exp(x[0]), math.exp(x[1]))
        return weights[0] * dy + weights[1] * du

    def room(x: np.ndarray) -> float:
        count["ms"] += 1
        m = ms(plant, math.exp(x[0]), math.exp(x[1]))
        return ms_target - m if math.isfinite(m) else -1e3

    r = minimize(cost, np.log([kc_start, ti_start]), method="SLSQP",
                 constraints=[{"type": "ineq", "fun": room}],
                 options={"ftol": 1e-12, "maxiter": 200})
    kc, ti = (float(v) for v in np.exp(r.x))
    dy, du = iae(plant, kc, ti)
    m = ms(plant, kc, ti)
    return OptimalPi(kc=kc, ti=ti, ms=m, iae_dy=dy, iae_du=du,
                     cost=weights[0] * dy + weights[1] * du, weights=weights,
                     ms_target=ms_target, n_ms=count["ms"] + 1, n_iae=count["iae"] + 1,
                     active=abs(m - ms_target) < 1e-6, seconds=time.perf_counter() - t0)


def lag_cancelling_dy_iae(k: float, theta: float, t_end: float, n: int) -> float:
    """The closed form the test checks :func:`iae` against: the PI with ``Ti = tau`` on
    the FOPDT leaves ``L = k e^(-theta s)/s`` (``k = Kc K/tau``), whose output-step error
    is ``e(t) = -sum_j (-k (t - j theta))^j/j! 1(t >= j theta)`` (the series of
    ``1/(s + k e^(-theta s))``); ``int |e|`` on ``n`` points up to ``t_end``."""
    t = np.linspace(0.0, t_end, n)
    e = np.zeros_like(t)
    for j in range(int(t_end / theta) + 1):
        m = t >= j * theta
        e[m] += (-k * (t[m] - j * theta)) ** j / math.factorial(j)
    return float(_block_iae(-e[None, :], t[1] - t[0])[0])


__all__ = ["DELAY_DOMINANT", "IMPROVED_BOUND", "RATIOS", "REFERENCE_MS", "SIMC_BOUND",
           "SIMC_CLAIMED_FROM", "Comparison", "Fopdt", "OptimalPi", "compare", "iae",
           "lag_cancelling_dy_iae", "ms", "optimal_pi", "rule_pi", "slsqp_optimum"]
