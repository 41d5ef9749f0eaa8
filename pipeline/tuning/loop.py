"""The tuned loop simulated: a PID controller on a linear plant with an exact dead time,
actuator limits and back-calculation anti-windup, evaluated on a setpoint step followed
by a load (input) disturbance step.

The plant is ``G(s) = num(s)/den(s) e^(-delay s)`` in deviation variables, at rest before
``t = 0``. Its rational part is discretised exactly by zero-order hold (``tf2ss`` then
``cont2discrete``) and the dead time is an integer number of samples (a FIFO of the
plant input), so the sampled plant is exact for a held input. The controller is the
ideal (ISA) PID of Åström & Hägglund, Advanced PID Control (ISA, 2006), Ch. 3 (setpoint
weight ``b``, derivative on the measurement through a first-order filter) with
back-calculation anti-windup (Sec. 3.5, integrator windup), sampled at the plant's step and computed
without a computational delay (the hold adds an effective lag of ``dt/2``):

* integral by forward Euler, ``I += Kc dt/Ti e + (1 - exp(-dt/Tt)) (u - v)`` (the
  tracking gain is ``dt/Tt`` to first order, as in the book's computer code, but stays
  stable for any ``Tt > 0``);
* the filtered derivative discretised exactly for a measurement linear between samples
  (ramp invariance, as in the book's computer implementation):
  ``D = a D - Kc Td (1 - a)/dt (y - y_prev)``, ``a = exp(-dt/Tf)``.

A proper plant without dead time closes an algebraic loop through its feedthrough; it is
solved exactly (the saturated loop has one solution when ``1 + D_plant c > 0``).

The evaluation follows Skogestad, "Simple analytic rules for model reduction and PID
controller tuning", J. Process Control 13 (2003) 291-309: a setpoint step at ``t = 0``
and a load step at the plant input at ``t_load``, each judged on its own phase.

Speed: a loop with a dead time of at least :data:`MIN_BLOCK` samples is simulated a
dead time at a time (:func:`_block_loop`: the plant's state-space response to the input
it already has, the controller's linear parts as filters, the integral with its limiter
segment by segment), a few ms for 10-50 k samples;
otherwise a Python loop over the samples with scalar floats, measured 2.5 to 5 us per
sample for a first- or second-order plant (20 k samples in 0.05 to 0.1 s on one core),
6 us for a fifth-order plant.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import signal

#: Samples per smallest characteristic time (plant, delay, Ti, Tt, closed loop).
SAMPLES_PER_TIME = 100
#: Samples per derivative filter time constant (the filter is discretised exactly for a
#: ramp; its fast output is smoothed by the plant).
SAMPLES_PER_FILTER = 20
#: The default grid stops growing here (the step is lengthened instead).
MAX_STEPS = 200_000
#: The default setpoint phase lasts this many characteristic times.
PHASE_TIMES = 5.0
#: The loop is simulated in blocks of the dead time when it is at least this many samples
#: and the block's matrices (its samples times the plant's order) hold at most
#: :data:`MAX_BLOCK_TERMS` numbers (:func:`_block_loop`), else sample by sample.
MIN_BLOCK = 8
MAX_BLOCK_TERMS = 2_000_000
#: The settling band, as a fraction of the step size (or of the load's effect).
SETTLING_BAND = 0.02


@dataclass(frozen=True)
class Pid:
    """Ideal (ISA) form with a derivative filter (Åström & Hägglund 2006, Ch. 3):
    ``u = Kc [b r - y + (1/(Ti s)) (r - y) - Td s/(Tf s + 1) y]`` (derivative on the
    measurement, setpoint weight ``b``). ``Ti = math.inf`` means no integral action,
    ``Td = 0`` no derivative; ``Tf`` is the derivative filter time constant (``Td/N``
    in the book, ``N`` about 2 to 20), 0 allowed only when ``Td == 0``."""

    Kc: float
    Ti: float = math.inf
    Td: float = 0.0
    Tf: float = 0.0
    b: float = 1.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.Kc) and math.isfinite(self.b)):
            raise ValueError("Kc and b must be finite")
        if not self.Ti > 0:
            raise ValueError("Ti must be > 0 (math.inf: no integral action)")
        if not (math.isfinite(self.Td) and self.Td >= 0 and math.isfinite(self.Tf)
                and self.Tf >= 0):
            raise ValueError("Td and Tf must be finite and >= 0")
        if self.Td > 0 and self.Tf == 0:
            raise ValueError("a derivative (Td > 0) needs a filter (Tf > 0)")


@dataclass(frozen=True)
class StepMetrics:
    """One phase of the response (Skogestad 2003's setpoint and load evaluation).

    ``overshoot``: setpoint phase, the fraction of ``|r_step|`` by which ``y`` goes beyond
    its final value (``y`` at the phase end) in the step's direction; load phase, the
    fraction of the peak deviation by which ``y`` crosses the setpoint to the other side
    on recovering. ``peak_deviation``: max ``|y - r|`` over the phase. ``settling_time``:
    from the phase start until ``|y - r|`` stays within 2 % of ``|r_step|`` (setpoint) or
    of the load's open-loop steady effect ``|K d_step|`` (load; the peak deviation for an
    integrating or zero-gain plant), linearly interpolated between samples; ``math.inf``
    when the last sample is still outside (a P controller's offset never settles), 0 for
    a zero step. ``u_peak``: max ``|u|`` (deviation from the operating point).
    ``saturated``: the limiter clipped the controller output during the phase."""

    iae: float
    overshoot: float
    peak_deviation: float
    settling_time: float
    u_peak: float
    saturated: bool


@dataclass(frozen=True, eq=False)
class LoopResponse:
    """Deviation variables on the grid ``t``; ``u`` is the actuator output after the
    limits (the plant input is ``u + d``). ``setpoint`` covers ``[0, t_load]``, ``load``
    ``[t_load, t_end]`` (the samples before ``t_load``, and from it); ``anti_windup`` is the
    flag as asked (it acts only with integral action)."""

    t: np.ndarray
    r: np.ndarray
    y: np.ndarray
    u: np.ndarray
    d: np.ndarray
    setpoint: StepMetrics
    load: StepMetrics
    anti_windup: bool


def _polys(num: ArrayLike, den: ArrayLike) -> tuple[np.ndarray, np.ndarray, int]:
    """``num``, ``den`` as float arrays without leading zeros or common roots at ``s = 0``,
    and the number of poles at the origin."""
    n = np.trim_zeros(np.atleast_1d(np.asarray(num, dtype=float)), "f")
    d = np.trim_zeros(np.atleast_1d(np.asarray(den, dtype=float)), "f")
    if d.size == 0 or n.size == 0 or not (np.all(np.isfinite(n)) and np.all(np.isfinite(d))):
        raise ValueError("num and den must be finite and nonzero")
    if n.size > d.size:
        raise ValueError("the plant must be proper (deg num <= deg den)")
    while n.size > 1 and d.size > 1 and n[-1] == 0 and d[-1] == 0:
        n, d = n[:-1], d[:-1]
    n0 = d.size - np.trim_zeros(d, "b").size
    return n, d, n0


def _controller_tf(pid: Pid) -> tuple[np.ndarray, np.ndarray]:
    """The feedback path ``Kc (1 + 1/(Ti s) + Td s/(Tf s + 1))`` as ``(num, den)``."""
    terms = [(np.array([pid.Kc]), np.array([1.0]))]
    if math.isfinite(pid.Ti):
        terms.append((np.array([pid.Kc]), np.array([pid.Ti, 0.0])))
    if pid.Td > 0:
        terms.append((np.array([pid.Kc * pid.Td, 0.0]), np.array([pid.Tf, 1.0])))
    cn, cd = terms[0]
    for tn, td in terms[1:]:
        cn, cd = np.polyadd(np.polymul(cn, td), np.polymul(tn, cd)), np.polymul(cd, td)
    return cn, cd


def _times(p: np.ndarray) -> np.ndarray:
    """``1/|Re p|`` of the nonzero roots ``p`` (``1/|p|`` when on the imaginary axis)."""
    p = p[np.abs(p) > 1e-12 * max(1.0, float(np.max(np.abs(p), initial=0.0)))]
    re = np.abs(p.real)
    return 1.0 / np.where(re > 1e-9 * np.abs(p), re, np.abs(p))


def _metrics(t: np.ndarray, r: np.ndarray, y: np.ndarray, u: np.ndarray, clipped: np.ndarray,
             ref: float, setpoint: bool) -> StepMetrics:
    e = r - y
    t0 = float(t[0])
    iae = float(np.trapezoid(np.abs(e), t))
    peak = float(np.max(np.abs(e)))
    if setpoint:
        size = abs(float(r[-1]))
        s = math.copysign(1.0, float(r[-1]))
        over = max(0.0, float(np.max(s * (y - y[-1])))) / size if size > 0 else 0.0
    else:
        i = int(np.argmax(np.abs(e)))
        s = math.copysign(1.0, float(e[i]))
        over = max(0.0, float(np.max(-s * e[i:]))) / peak if peak > 0 else 0.0
    band = SETTLING_BAND * ref
    out = np.flatnonzero(np.abs(e) > band)
    if ref <= 0 or out.size == 0:
        settle = 0.0
    elif out[-1] == e.size - 1:
        settle = math.inf
    else:  # the last exit from the band, interpolated between samples
        k = int(out[-1])
        a, c = abs(float(e[k])), abs(float(e[k + 1]))
        settle = float(t[k] + (t[k + 1] - t[k]) * (a - band) / (a - c)) - t0
    return StepMetrics(iae, over, peak, settle, float(np.max(np.abs(u))), bool(np.any(clipped)))


def simulate_loop(num: ArrayLike, den: ArrayLike, delay: float, pid: Pid, *, r_step: float = 1.0,
                  d_step: float | None = None, t_load: float | None = None,
                  t_end: float | None = None, dt: float | None = None,
                  u_limits: tuple[float, float] | None = None, anti_windup: bool = True,
                  tracking_time: float | None = None) -> LoopResponse:
    """Simulate the loop (see the module docstring): a setpoint step ``r_step`` at 0 and a
    load ``d_step`` added to the plant input (after the limiter) from ``t_load`` on.

    ``u_limits`` = ``(lo, hi)`` in deviation variables, ``lo <= 0 <= hi``. Anti-windup by
    back-calculation (Åström & Hägglund 2006, Sec. 3.5: ``dI/dt = Kc/Ti e + (sat(v) -
    v)/Tt``); ``tracking_time`` ``Tt`` defaults to the book's rule of thumb
    ``sqrt(Ti Td)`` for a PID and to ``Ti/2`` for a PI (no single rule there; the book
    asks for ``Td < Tt < Ti``). ``anti_windup=False``: the integrator integrates ``e``
    regardless of the limits (windup).

    Defaults, from the characteristic time ``Tc`` = sum of ``1/|Re p|`` over the plant's
    nonzero poles + ``delay`` + ``Ti`` (when finite) + ``1/|Kc Kv|`` for an integrating
    plant of velocity gain ``Kv`` (1 s when all are absent): ``t_load = 5 max(Tc, 2 x slowest
    delay-free closed-loop time constant)`` (a setpoint step ``t_end/2`` if only ``t_end``
    is given); ``t_end = 2 t_load``; ``d_step = r_step/|K|`` (``K`` the steady-state gain;
    ``r_step/(|Kv| Tc)`` for an integrating plant, a load that alone would ramp the output
    by ``r_step`` in ``Tc``; ``r_step`` 0 counts as 1); ``dt`` = 1/100 of the smallest of
    the plant's ``1/|p|``, ``delay``, ``Ti``, ``Tt`` and the delay-free closed loop's
    ``1/|p|`` (no shorter than ``delay``), and at most ``Tf/20``, lengthened to keep within
    200 k samples, then shortened to ``delay/ceil(delay/dt)`` (unless that needs more than
    400 k samples: a delay that short against the loop is rounded to whole samples). A
    given ``dt`` must divide ``delay`` into an integer number of samples (else
    ValueError)."""
    n, d, n0 = _polys(num, den)
    delay = float(delay)
    if not (math.isfinite(delay) and delay >= 0):
        raise ValueError("delay must be finite and >= 0")
    lo, hi = (-math.inf, math.inf) if u_limits is None else map(float, u_limits)
    if not lo <= 0.0 <= hi:
        raise ValueError("u_limits must satisfy lo <= 0 <= hi (deviation variables)")
    integral = math.isfinite(pid.Ti)
    if tracking_time is None:
        tracking_time = math.sqrt(pid.Ti * pid.Td) if pid.Td > 0 else pid.Ti / 2
    if not tracking_time > 0:
        raise ValueError("tracking_time must be > 0")
    aw = anti_windup and integral and math.isfinite(tracking_time)

    # characteristic times
    plant_poles = np.roots(d)
    kv = n[-1] / d[-1 - n0]  # steady-state gain, or velocity gain when integrating
    tc = float(np.sum(_times(plant_poles))) + delay + (pid.Ti if integral else 0.0)
    if n0 and pid.Kc != 0:
        tc += 1.0 / abs(pid.Kc * kv)
    tc = tc if tc > 0 else 1.0
    cn, cd = _controller_tf(pid)
    cl = np.roots(np.polyadd(np.polymul(d, cd), np.polymul(n, cn)))
    cl_times = _times(cl)
    if t_load is None:
        t_load = PHASE_TIMES * max(tc, 2.0 * float(np.max(cl_times, initial=0.0)))
        if t_end is not None and t_load >= t_end:
            t_load = t_end / 2
    t_end = 2.0 * t_load if t_end is None else float(t_end)
    if not 0 < t_load < t_end < math.inf:
        raise ValueError("need 0 < t_load < t_end < inf")
    if d_step is None:
        scale = r_step if r_step != 0 else 1.0
        d_step = scale / (abs(kv) * tc) if n0 else scale / abs(kv) if kv != 0 else scale

    if dt is None:  # a dead time caps the loop's speed: faster delay-free poles are fictitious
        cand = [*(1.0 / np.abs(plant_poles[np.abs(plant_poles) > 0])),
                *np.maximum(1.0 / np.abs(cl[np.abs(cl) > 0]), delay)]
        cand += [x for x in (delay, pid.Ti, tracking_time if aw else 0.0) if 0 < x < math.inf]
        dt = min(min(cand, default=tc) / SAMPLES_PER_TIME,
                 pid.Tf / SAMPLES_PER_FILTER if pid.Tf > 0 else math.inf)
        dt = max(dt, t_end / MAX_STEPS)
        # a whole number of samples in the delay; a delay far below the loop's time scale
        # (that would need more than 2 MAX_STEPS) is rounded to whole samples instead
        fine = delay / math.ceil(delay / dt - 1e-9) if delay > 0 else dt
        dt = fine if t_end / fine <= 2 * MAX_STEPS else dt
        given_dt = False
    else:
        given_dt = True
    dt = float(dt)
    nd = round(delay / dt)
    if not dt > 0 or (given_dt and abs(nd * dt - delay) > 1e-9 * max(delay, dt)):
        raise ValueError("dt must be > 0 and divide the delay into whole samples")
    steps = round(t_end / dt)
    k_load = round(t_load / dt)

    with warnings.catch_warnings():  # a lead-lag's leading zero coefficient: harmless here
        warnings.simplefilter("ignore", signal.BadCoefficients)
        a_, b_, c_, d_ = signal.tf2ss(n, d)
    ad, bd, cc, dd, _ = signal.cont2discrete((a_, b_, c_, d_), dt, method="zoh")
    A, B, C, Dp = ad.tolist(), bd[:, 0].tolist(), cc[0].tolist(), float(dd[0, 0])

    kc, bw = pid.Kc, pid.b
    ki = kc * dt / pid.Ti if integral else 0.0
    kt = -math.expm1(-dt / tracking_time) if aw else 0.0
    a_d = math.exp(-dt / pid.Tf) if pid.Td > 0 else 0.0
    k_d = kc * pid.Td * (1.0 - a_d) / dt if pid.Td > 0 else 0.0
    direct = nd == 0 and Dp != 0.0
    gain = kc + k_d  # v = a0 - gain * y within one sample
    if direct and not 1.0 + Dp * gain > 0:
        raise ValueError("the delay-free loop through the plant's feedthrough is ill-posed")

    rk = float(r_step)
    blocks = _block_loop(ad, bd[:, 0], cc[0], Dp, nd, (kc, bw, ki, kt, a_d, k_d), (lo, hi),
                         rk, d_step, k_load, steps)
    if blocks is not None:
        y_, u_, cl_ = blocks
    else:
        y_, u_, cl_ = _sample_loop(A, B, C, Dp, nd, (kc, bw, ki, kt, a_d, k_d, gain), direct,
                                   (lo, hi), rk, d_step, k_load, steps)
    t = np.arange(steps + 1) * dt
    r = np.full(steps + 1, rk)
    dv = np.where(np.arange(steps + 1) >= k_load, d_step, 0.0)
    ph1, ph2 = slice(0, k_load), slice(k_load, steps + 1)  # y[k_load] may hold the load
    load_ref = abs(kv * d_step) if not n0 and kv != 0 else 0.0
    m1 = _metrics(t[ph1], r[ph1], y_[ph1], u_[ph1], cl_[ph1], abs(rk), True)
    e2 = np.abs(r[ph2] - y_[ph2])
    m2 = _metrics(t[ph2], r[ph2], y_[ph2], u_[ph2], cl_[ph2],
                  load_ref or float(np.max(e2)) if d_step != 0 else 0.0, False)
    return LoopResponse(t, r, y_, u_, dv, m1, m2, bool(anti_windup))


def _sample_loop(A, B, C, Dp: float, nd: int, gains, direct: bool, limits, rk: float,
                 d_step: float, k_load: int, steps: int
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(y, u, clipped)`` of the loop, sample by sample (see the module docstring): a
    Python loop over scalar floats."""
    kc, bw, ki, kt, a_d, k_d, gain = gains
    lo, hi = limits
    order = len(B)
    ys, us, ws = [0.0] * (steps + 1), [0.0] * (steps + 1), [0.0] * (steps + 1)
    clipped = [False] * (steps + 1)
    x = [0.0] * order
    integ = dterm = y_prev = 0.0
    for k in range(steps + 1):
        dk = d_step if k >= k_load else 0.0
        cx = sum(ci * xi for ci, xi in zip(C, x, strict=True))
        if direct:  # solve y = Cx + Dp (sat(v) + d), v = a0 - gain y
            a0 = kc * bw * rk + integ + a_d * dterm + k_d * y_prev
            v = (a0 - gain * (cx + Dp * dk)) / (1.0 + Dp * gain)
            clip = v > hi or v < lo
            uk = hi if v > hi else lo if v < lo else v
            y = cx + Dp * (uk + dk)
            dterm = a_d * dterm - k_d * (y - y_prev)
            if clip:
                v = kc * (bw * rk - y) + integ + dterm
        else:
            y = cx + Dp * (ws[k - nd] if k >= nd else 0.0)
            dterm = a_d * dterm - k_d * (y - y_prev)
            v = kc * (bw * rk - y) + integ + dterm
            clip = v > hi or v < lo
            uk = hi if v > hi else lo if v < lo else v
        integ += ki * (rk - y) + kt * (uk - v)
        ws[k] = uk + dk
        wd = ws[k - nd] if k >= nd else 0.0
        x = [sum(aij * xj for aij, xj in zip(ai, x, strict=True)) + bi * wd
             for ai, bi in zip(A, B, strict=True)]
        ys[k], us[k], clipped[k], y_prev = y, uk, clip, y
    return np.array(ys), np.array(us), np.array(clipped)


def _block_loop(ad: np.ndarray, bd: np.ndarray, cd: np.ndarray, Dp: float, nd: int, gains,
                limits: tuple[float, float], rk: float, d_step: float, k_load: int, steps: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(y, u, clipped)``: :func:`_sample_loop`'s recursion ``nd`` samples at a time.
    Within such a block the plant's input is what the controller sent ``nd`` samples
    earlier, all known, so the block's output is the sampled plant's response from its
    state at the block's start and to that input, in state space: ``y[j] = C A^j x0 +
    sum_{i<=j} h[j-i] v[i]`` with the Markov parameters ``h = (Dp, C B, C A B, ...)`` (a
    convolution), and the state after it is ``A^m x0 + sum_i A^(m-1-i) B v[i]``. The
    controller's proportional and derivative parts are filters of that output
    (``scipy.signal.lfilter``, their states carried from block to block). What is left
    is the integral with its back-calculation, ``I += ki e + kt (sat(v) - v)`` with ``v =
    p + I``: a cumulative sum while ``v`` stays within the limits and, while it is held
    at a limit ``L``, the first-order recursion ``I = (1 - kt) I + ki e + kt (L - p)``
    (:func:`_integral`). Why: the per-sample loop costs 2.5-6 us a sample, 0.26-0.35 s
    of a 100-sample log's 1.9 s of ``identify`` (two simulations of 11-46 k samples);
    the blocks (at least :data:`MIN_BLOCK` samples: a dead time is at least 100 of the
    default grid's), a few ms. Not as a transfer function: ``lfilter`` on the plant's
    expanded polynomial lost digits on slow poles and diverged from order 5 (its roots,
    clustered near ``z = 1``, left the unit circle), on the whole loop's it lost 6
    digits at order 2. None (the per-sample loop) when the dead time is shorter than a
    block or the block's matrices would exceed :data:`MAX_BLOCK_TERMS`."""
    if nd < MIN_BLOCK:
        return None
    kc, bw, ki, kt, a_d, k_d = gains
    r = bd.size
    if nd * max(r, 1) > MAX_BLOCK_TERMS:
        return None
    # the block's response from its initial state and to its input: O[j] = C A^j, the
    # Markov parameters h = (Dp, C B, C A B, ...) and R = (A^(nd-1) B, ..., B)
    obs = np.empty((nd, r))
    reach = np.empty((r, nd))
    row, col = cd.astype(float), bd.astype(float)
    for j in range(nd):
        obs[j], reach[:, nd - 1 - j] = row, col
        row, col = row @ ad, ad @ col
    markov = np.concatenate([[Dp], obs @ bd])
    a_nd = np.linalg.matrix_power(ad, nd)
    x = np.zeros(r)
    n = steps + 1
    y, u, w = np.empty(n), np.empty(n), np.zeros(n)
    clipped = np.zeros(n, bool)
    zd = np.zeros(1)  # the derivative filter D = -k_d (1 - q)/(1 - a_d q) y, q = z^-1
    integ = 0.0
    for s in range(0, n, nd):
        e = min(s + nd, n)
        m = e - s
        v = w[s - nd: e - nd] if s else np.zeros(m)  # the plant's input, nd samples late
        conv = np.convolve if m <= 256 else signal.oaconvolve
        y[s:e] = obs[:m] @ x + conv(v, markov[:m])[:m]
        x = (a_nd if m == nd else np.linalg.matrix_power(ad, m)) @ x + reach[:, nd - m:] @ v
        dterm, zd = signal.lfilter([-k_d, k_d], [1.0, -a_d], y[s:e], zi=zd)
        err = rk - y[s:e]
        integ = _integral(kc * (bw * rk - y[s:e]) + dterm, err, integ, (ki, kt), limits,
                          u[s:e], clipped[s:e])
        w[s:e] = u[s:e]
        if e > k_load:
            w[max(s, k_load):e] += d_step
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(u))):
        return None
    return y, u, clipped


def _integral(p: np.ndarray, err: np.ndarray, integ: float, gains, limits, u: np.ndarray,
              clipped: np.ndarray) -> float:
    """The controller over a block whose proportional and derivative parts ``p`` and error
    ``err`` are known: ``v = p + I``, ``u = sat(v)`` (written into ``u``, ``clipped`` where
    the limiter acts), ``I += ki e + kt (u - v)`` from ``integ``; returns the integral
    after the block. Segment by segment: within the limits ``I`` is a cumulative sum of
    ``ki e``; held at a limit ``L`` it obeys ``I = c I + ki e + kt (L - p)``, ``c = 1 -
    kt``, a first-order filter; each segment ends where ``v`` crosses a limit."""
    ki, kt = gains
    lo, hi = limits
    m, k = p.size, 0
    while k < m:
        acc = np.empty(m - k)
        acc[0] = integ
        np.cumsum(ki * err[k:m - 1], out=acc[1:])
        acc[1:] += integ
        v = p[k:] + acc
        out = np.flatnonzero((v > hi) | (v < lo))
        j = m if out.size == 0 else k + int(out[0])
        u[k:j] = v[: j - k]
        if j == m:
            return float(acc[-1] + ki * err[m - 1])
        integ = float(acc[j - k])
        lim = hi if v[j - k] > hi else lo
        g = ki * err[j:] + kt * (lim - p[j:])
        held = np.empty(m - j)
        held[0] = integ
        if m - j > 1:
            held[1:] = signal.lfilter([1.0], [1.0, -(1.0 - kt)], g[:-1], zi=[(1.0 - kt) *
                                                                            integ])[0]
        v = p[j:] + held
        free = np.flatnonzero(~(v > hi) if lim == hi else ~(v < lo))
        i = m if free.size == 0 else j + int(free[0])
        u[j:i] = lim
        clipped[j:i] = True
        if i == m:
            return float((1.0 - kt) * held[-1] + g[-1])
        integ = float(held[i - j])
        k = i
    return integ

