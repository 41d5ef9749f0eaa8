"""The simulation engine: a :class:`~pipeline.models.ProcessModel` driven by a measured
input, exact under a zero-order hold, on uniform and irregular grids.

Everything is in deviation variables from the steady operating point ``(u0, y0)``: the
state starts at rest, ``y_hat = y0 + K x`` with ``x`` the unit-gain response to the held
input ``u - u0`` (the lecture's "x(0) = y0", seed 001, with the incremental form of
ERRATA [S1] 11). :func:`forced_response` is that ``x``, the one computation under every
simulation: validation, plots, the per-step gains and every residual of the least-squares
fits (:mod:`pipeline.simulation.regressors` adds their free and offset columns).
:func:`simulate` is ``y0 + K x`` of a model, its filter cached per model.

Two exact paths on a uniform grid:

* a rational model of order <= 2 (every structure but the long and non-integer equal-lag
  chains): its exact ZOH filter in closed form (:func:`pipeline.simulation.zoh.filter_of`)
  applied by ``scipy.signal.lfilter``; the dead time, whole or fractional, is in the
  filter's leading zeros and numerator;
* anything else (equal-lag chains up to n = 20, non-integer n): the exact ZOH pulse
  response ``h[k] = S(k dt - delay) - S((k-1) dt - delay)`` from the closed-form step
  response ``S``, applied by FFT convolution. An expanded (Ts+1)^n denominator discretised
  at a short sample time has n poles near 1 and is numerically useless; the pulse response
  has no such problem.

Which grid is uniform is one rule, :func:`pipeline.record.uniform_step` at
:data:`UNIFORM_REL_TOL`: pass ``dt`` when it is known (a record's ``sample_time``);
otherwise it is found from ``t`` (one pass over the grid).

Irregular grids (:func:`simulate_irregular`): the state-space form propagated exactly over
each interval with the input held, one discretisation per distinct interval (within
:data:`pipeline.simulation.zoh.STEP_REL_TOL`), the dead time handled by reading the state at
``t - delay``: O(samples) time and memory whatever the grid. A non-integer order n has no
state space: the exact superposition of closed-form step responses while that is
affordable, else a uniform grid of bounded size (input held, output interpolated back).

A long input is filtered and convolved :data:`pipeline.memory.CHUNK` samples at a time
into the one output array (the same numbers as one pass, without the input's deviation
and the filter's temporaries as long as the record).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from scipy import signal

from ..memory import CHUNK
from ..models import ProcessModel
from ..record import uniform_step
from . import zoh

#: A grid is uniform for the simulator when every interval is within this share of the
#: mean interval (:func:`pipeline.record.uniform_step`).
UNIFORM_REL_TOL = 1e-4


def simulate(model: ProcessModel, t, u, u0: float, y0: float, *,
             dt: float | None = None) -> np.ndarray:
    """Simulated output at times ``t`` for input ``u`` from the operating point (u0, y0).

    ``dt``: the uniform sample time of ``t`` when the caller knows it (trusted, not
    re-checked); None: found from ``t`` (irregular grids take the exact irregular path).
    """
    t = np.asarray(t, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    if t.size == 0:
        return np.empty(0)
    if t.size == 1:
        return np.full(1, float(y0))
    if dt is None:
        dt = uniform_step(t, UNIFORM_REL_TOL)
        if dt is None:
            return simulate_irregular(model, t, u, u0, y0)
    x = _uniform(model.structure, model.params, u, float(dt), float(u0),
                 zoh.zoh_filter(model, dt), None)
    x *= model.K  # in place: x is a fresh array
    x += float(y0)
    return x


def forced_response(structure: str, p: Mapping[str, float], t: np.ndarray, du: np.ndarray,
                    dt: float | None = None, *, u0: float = 0.0,
                    minus: np.ndarray | None = None) -> np.ndarray:
    """The unit-gain response of ``structure`` (parameters ``p``, their gain ignored) from
    rest to the held input ``du``, a deviation from ``u0`` (subtracted chunk by chunk, so
    a caller can give the measured input of a long record as it is); ``dt`` is the
    uniform sample time (None: found from ``t``, irregular grids take the irregular
    path). With ``minus``, the response less ``minus``, written into ``minus``'s array (a
    long record's filter subtracts it chunk by chunk: no second record-long array); the
    same numbers as ``np.subtract(response, minus)``. The filter is made for ``p`` on
    every call (:func:`pipeline.simulation.zoh.filter_of`): a refinement's search never
    asks for the same parameters twice."""
    n = du.size
    if n == 0:
        x = np.empty(0)
        return x if minus is None else np.subtract(x, minus, out=minus)
    dt = uniform_step(t, UNIFORM_REL_TOL) if dt is None else dt
    if dt is None:
        unit = ProcessModel(structure, {**p, "K": 1.0})
        x = simulate_irregular(unit, t, du - u0 if u0 else du, 0.0, 0.0)
        return x if minus is None else np.subtract(x, minus, out=minus)
    return _uniform(structure, p, du, float(dt), u0, zoh.filter_of(structure, p, dt), minus)


def _uniform(structure: str, p: Mapping[str, float], du: np.ndarray, dt: float, u0: float,
             f: zoh.Filter | None, minus: np.ndarray | None) -> np.ndarray:
    """The unit-gain response on a uniform grid: the filter ``f``, or without one the
    exact pulse response convolved (:func:`forced_response`)."""
    n = du.size
    if f is None:
        m = ProcessModel(structure, {**p, "K": 1.0})
        x = convolved(pulse_response(m, dt, pulse_length(m, dt, n)), du, u0)
    elif n > CHUNK:
        return _filtered(f.b, f.a, f.lag, du, u0, minus)
    else:
        if u0:
            du = du - u0
        if f.lag >= n:
            x = np.zeros(n)
        else:
            x = signal.lfilter(f.b, f.a, du[: n - f.lag])
            x = np.concatenate([np.zeros(f.lag), x]) if f.lag else x
    return x if minus is None else np.subtract(x, minus, out=minus)


def _filtered(b: np.ndarray, a: np.ndarray, lag: int, u: np.ndarray, u0: float,
              minus: np.ndarray | None = None) -> np.ndarray:
    """``lfilter(b, a, u - u0)`` delayed by ``lag`` samples (zeros before), filtered
    :data:`pipeline.memory.CHUNK` samples at a time into the one output array (the filter's
    state carried from chunk to chunk: the same output to the bit), so that the
    record-long input deviation, the filter's output and its copy shifted by the dead time
    (three record-long arrays) are one output array; with ``minus`` that array
    is ``minus``'s, each chunk's output less it (:func:`forced_response`)."""
    n = u.size
    out = np.zeros(n) if minus is None else minus
    if minus is not None:  # the zeros before the dead time, less minus there
        np.subtract(0.0, out[:lag], out=out[:lag])
    z = np.zeros(max(a.size, b.size) - 1)
    for s in range(0, n - lag, CHUNK):
        e = min(s + CHUNK, n - lag)
        v, z = signal.lfilter(b, a, u[s:e] - u0 if u0 else u[s:e], zi=z)
        if minus is None:
            out[lag + s: lag + e] = v
        else:
            np.subtract(v, out[lag + s: lag + e], out=out[lag + s: lag + e])
    return out


def pulse_length(model: ProcessModel, dt: float, n: int) -> int:
    """The samples of the pulse response a convolution over ``n`` samples computes: all
    ``n`` up to :data:`pipeline.memory.CHUNK`; beyond, the model's memory
    (:func:`pipeline.simulation.memory`: past it the pulse response is below 1e-17 of the
    gain, under :func:`pulse_response`'s cut) plus one, where it has one: no pulse
    response as long as a long record (with its temporaries, several times the record's
    size)."""
    if n <= CHUNK:
        return n
    mem = zoh.memory(model, dt)
    return n if mem is None else min(n, mem + 1)


def convolved(h: np.ndarray, u: np.ndarray, u0: float = 0.0) -> np.ndarray:
    """``convolve(u - u0, h)[:n]``: FFT (overlap-add) beyond 64 taps. Up to
    :data:`pipeline.memory.CHUNK` samples (or taps) one convolution; beyond, a chunk of the
    input at a time added into the one output array (no whole-input deviation, and no FFT
    temporaries as long as the record; the sums are the whole convolution's in another
    order: the same to rounding)."""
    n = u.size
    conv = signal.oaconvolve if h.size > 64 else np.convolve
    if n <= CHUNK or h.size >= CHUNK:  # (a pulse response this long: chunks save nothing)
        return conv(u - u0 if u0 else u, h)[:n]
    out = np.zeros(n)
    for s in range(0, n, CHUNK):
        c = conv(u[s: s + CHUNK] - u0 if u0 else u[s: s + CHUNK], h)
        stop = min(n, s + c.size)
        out[s:stop] += c[: stop - s]
    return out


def pulse_response(model: ProcessModel, dt: float, n: int) -> np.ndarray:
    """Exact ZOH pulse response of ``model`` at sample time ``dt``, at most ``n`` long.

    Truncated where the step response has settled to double precision.
    """
    k = np.arange(n, dtype=np.float64) * dt
    h = np.diff(model.unit_step(k), prepend=0.0)  # h[0] = S(0) - S(-dt) = 0
    big = np.flatnonzero(np.abs(h) > 1e-15 * max(np.abs(h).sum(), 1e-300))
    return h[: big[-1] + 1] if big.size else h[:1]


#: Irregular grids without a state space: superpose step responses while changes x
#: samples stays below this.
SUPERPOSITION_BUDGET = 5e7
#: ... else a uniform grid of at most this many points.
MAX_GRID = 2_000_000


def simulate_irregular(model: ProcessModel, t: np.ndarray, u: np.ndarray, u0: float,
                       y0: float) -> np.ndarray:
    """Exact ZOH simulation on an irregular grid (see the module docstring); a staircase
    input (:data:`SUPERPOSED_FIRST`, :data:`FEW_CHANGES`) by superposition of the
    closed-form step responses (:func:`_superposed`)."""
    changes = int(np.count_nonzero(np.diff(u, prepend=float(u0))))
    if changes <= SUPERPOSED_FIRST:
        return _superposed(model, t, u, u0, y0)
    ss = zoh.state_space(model)
    if ss is None:
        return _irregular_without_state_space(model, t, u, u0, y0)
    A, B, C, D = ss
    du = u - float(u0)
    n = t.size
    # change points of the held input (t) and read points (t - delay), input first on a tie
    # (right-continuous: a delayed step is seen at the sample where it arrives)
    reads = t - model.delay
    pts = np.concatenate([t, reads])
    kind = np.concatenate([np.zeros(n, np.int8), np.ones(n, np.int8)])
    order = np.lexsort((kind, pts))
    pts, kind = pts[order], kind[order]
    src = np.where(kind == 0, order, -1)
    held = np.maximum.accumulate(src)  # the input sample held at each point (-1: before)
    u_held = np.where(held >= 0, du[np.maximum(held, 0)], 0.0)
    X = _propagate_modal(A, B[:, 0], pts, u_held)
    if X is None and changes <= FEW_CHANGES:
        return _superposed(model, t, u, u0, y0)
    if X is None:
        steps, group = zoh.step_groups(np.diff(pts))
        Phi, Gam = zoh.transitions(A, B, steps)
        X = _propagate(Phi, Gam[:, :, 0], group, u_held)
    read = kind == 1
    y = X[read] @ C[0] + D[0, 0] * u_held[read]
    y[held[read] < 0] = 0.0  # read before the first sample: at rest
    out = np.empty(n)
    out[order[read] - n] = y
    return out + float(y0)


#: A modal chunk spans at most this many time constants of its fastest mode (``e^300``
#: is far from overflow; within it the scaled sums keep full relative precision).
MODAL_SPAN = 300.0


def _propagate_modal(A: np.ndarray, b: np.ndarray, pts: np.ndarray, u_held: np.ndarray
                     ) -> np.ndarray | None:
    """:func:`_propagate`'s states by the modes of ``A`` (distinct eigenvalues), each mode's
    time-varying recursion ``z[i+1] = e^{l h_i} z[i] + expm1(l h_i)/l b u[i]`` solved in
    closed form over chunks: ``z[n] = e^{l (t_n - t_c)} (z[c] + sum_{k<n}
    e^{-l (t_{k+1} - t_c)} w[k])``, a cumulative sum (the same exact ZOH as the loop,
    rounding aside). A chunk spans at most :data:`MODAL_SPAN` time constants, so the
    scaled terms never overflow and the latest, largest ones set the precision. Why not
    the loop: a logger's jitter makes every interval distinct, and the per-point loop
    (about 2 us a point) made a 600-sample jittered log 3.5x the same log on a uniform
    grid (BENCHMARKS.md, "Jittered time stamps"). None (use the loop) for repeated or
    nearly repeated poles, or a mode so fast that the chunks would be a few samples."""
    n = A.shape[0]
    lam, V = np.linalg.eig(A)
    scale = max(float(np.max(np.abs(lam))), 1e-300)
    gaps = np.abs(lam[:, None] - lam[None, :]) + np.eye(n) * scale
    if n > 1 and not (float(np.min(gaps)) > 1e-4 * scale and np.linalg.cond(V) < 1e3):
        return None  # nearly repeated poles: the eigenvectors' conditioning costs digits
    fastest = float(np.max(np.abs(lam.real)))
    span = MODAL_SPAN / fastest if fastest > 0 else np.inf
    N = pts.size
    if N > 1 and (pts[-1] - pts[0]) / span > N / 64:
        return None  # chunks of a few samples: the loop is cheaper
    beta = np.linalg.solve(V, b.astype(complex))
    h = np.diff(pts)
    Z = np.empty((N, n), complex)
    for j in range(n):
        lj = lam[j]
        f = h + 0j if lj == 0 else np.expm1(lj * h) / lj
        w = f * beta[j] * u_held[:-1]
        z, c = 0j, 0
        while c < N - 1:
            e = max(int(np.searchsorted(pts, pts[c] + span, side="right")) - 1, c + 1)
            if e == c + 1:  # one interval longer than the span (a gap): step it directly
                Z[e, j] = np.exp(lj * h[c]) * z + w[c]
                z, c = Z[e, j], e
                continue
            tau = pts[c:e + 1] - pts[c]
            acc = np.empty(e - c + 1, complex)
            acc[0] = 0.0
            np.cumsum(np.exp(-lj * tau[1:]) * w[c:e], out=acc[1:])
            Z[c:e + 1, j] = np.exp(lj * tau) * (z + acc)
            z, c = Z[e, j], e
        Z[0, j] = 0.0
    return (Z @ V.T).real


def _propagate(Phi: np.ndarray, Gam: np.ndarray, group: np.ndarray, u_held: np.ndarray
               ) -> np.ndarray:
    """State at each point: ``x[i+1] = Phi[g] x[i] + Gam[g] u[i]`` from rest (``g`` the
    interval's group). A sequential recursion with time-varying coefficients, so a loop;
    on plain Python floats for one and two states (numpy's per-call overhead on arrays of
    two elements would dominate), about 2 us per point on the shared machine."""
    N, m = u_held.size, Phi.shape[1]
    X = np.zeros((N, m))
    if m == 1:
        p, g = Phi[:, 0, 0].tolist(), Gam[:, 0].tolist()
        x, xs = 0.0, [0.0] * N
        for i, (k, v) in enumerate(zip(group.tolist(), u_held[:-1].tolist(), strict=True)):
            x = p[k] * x + g[k] * v
            xs[i + 1] = x
        X[:, 0] = xs
    elif m == 2:
        P, G = Phi.reshape(-1, 4).tolist(), Gam.tolist()
        x0 = x1 = 0.0
        xs0, xs1 = [0.0] * N, [0.0] * N
        for i, (k, v) in enumerate(zip(group.tolist(), u_held[:-1].tolist(), strict=True)):
            a, b, c, d = P[k]
            g0, g1 = G[k]
            x0, x1 = a * x0 + b * x1 + g0 * v, c * x0 + d * x1 + g1 * v
            xs0[i + 1], xs1[i + 1] = x0, x1
        X[:, 0], X[:, 1] = xs0, xs1
    else:
        x = np.zeros(m)
        for i in range(N - 1):
            k = group[i]
            x = Phi[k] @ x + Gam[k] * u_held[i]
            X[i + 1] = x
    return X


#: An irregular grid whose input changes at most :data:`SUPERPOSED_FIRST` times is
#: simulated by superposition (:func:`_superposed`), and one that changes at most
#: :data:`FEW_CHANGES` times (a step test's staircase) when its poles are repeated or
#: nearly so (two lags, two lags and a zero, critical damping, an equal-lag chain: where
#: every search starts), which the modes' closed form refuses and the per-point loop
#: costs about 2 us a point: a 600-sample jittered four-step log spent 40 % of
#: ``identify --events all`` there (BENCHMARKS.md, "Jittered time stamps"). The steps'
#: closed forms cost a few ns a point each; against the modes' chunked sums (measured,
#: 1 % jittered grids, 2 vCPU): 600 samples and 5 changes 0.27 against 0.95-1.12 ms,
#: 100,000 and 6 changes 9.5 against 24-45 ms; with 32 changes the modes are 1.3-3x
#: cheaper. They are the closed forms the uniform engine's filters are made of,
#: written without cancellation near equal lags (:func:`pipeline.responses.
#: two_lag_step`).
SUPERPOSED_FIRST = 8
FEW_CHANGES = 32


def _superposed(model, t, u, u0, y0) -> np.ndarray:
    """``y0 + sum_k (u[k] - u[k-1]) S(t - t[k])``: a held input is a sum of steps, each
    answered by the model's closed-form step response ``S`` (its dead time included):
    exact on any grid, in O(samples x changes)."""
    du = np.diff(u, prepend=float(u0))
    y = np.full(t.size, float(y0))
    for k in np.flatnonzero(du):
        y[k:] += du[k] * model.unit_step(t[k:] - t[k])
    return y


def _irregular_without_state_space(model, t, u, u0, y0) -> np.ndarray:
    """A held input is a sum of steps, so ``y = y0 + sum_k (u[k] - u[k-1]) S(t - t[k])``
    with the closed-form step response S, exact while affordable. Otherwise (an input that
    changes at most samples of a long record) a uniform grid at a quarter of the smallest
    interval, at most :data:`MAX_GRID` points, input held, output interpolated back."""
    du = np.diff(u, prepend=float(u0))
    if np.count_nonzero(du) * t.size <= SUPERPOSITION_BUDGET:
        return _superposed(model, t, u, u0, y0)
    dt = max(float(np.min(np.diff(t))), float(np.median(np.diff(t)))) / 4
    dt = max(dt, float(t[-1] - t[0]) / MAX_GRID)
    grid = np.arange(t[0], t[-1] + dt / 2, dt)
    idx = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, t.size - 1)
    yg = simulate(model, grid, u[idx], u0, y0, dt=dt)
    return np.interp(t, grid, yg)
