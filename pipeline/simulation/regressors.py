"""The regressors of the least-squares refinement: the model's response to the measured input,
its free response from an unknown initial state, and the response to an input offset.

All three are *unit-gain* responses of one structure of :data:`pipeline.models.STRUCTURES`
(its ``step(p, t)``) with the dead time, in deviation variables, so the model output is
linear in the gain, the output offset and the initial state (the separable form that
:mod:`pipeline.refine` exploits):

    y_hat(t) = y0 + K x(t) + sum_j c_j b_j(t) [+ c_u s(t)]

* :func:`forced_response` ``x`` - the response from rest to the held input ``u - u_ref``
  (zero-order hold, exact): ``x[k] = sum_j h[k - j] du[j]`` with the exact ZOH pulse response
  ``h[k] = S(k dt - delay) - S((k-1) dt - delay)`` (the same definition as
  :func:`pipeline.simulation.engine.pulse_response`). For a rational model with at most two
  poles the pulse response obeys the recursion of the discrete poles ``z_i = exp(s_i dt)`` once the
  dead time has passed, so ``h`` is an IIR filter whose numerator is the exactly computed
  head of ``h`` convolved with the pole polynomial: exact for *fractional* delays too, and
  O(n) (this is the modified z-transform; Franklin, Powell, Workman, Digital Control of
  Dynamic Systems, 3rd ed., sec. 4.3.4). Other models (long equal-lag chains, non-integer
  n) use the FFT convolution, irregular grids the superposition of
  :func:`pipeline.simulation.simulate`.
* :func:`free_basis` ``b_j`` - the free response from an unknown state: the response after
  the window start to unknown input pulses on ``[-tau_j, 0)`` before it,
  ``b_j(t') = S(t' + tau_j) - S(t')``, with ``tau_j`` spread over the model's time scale.
  For a settling structure these decay to zero, for an integrator they tend to constants,
  so they span the free response of every structure, dead time included (the input still
  "in the pipe") - the idea of MATLAB's ``InitialCondition = 'estimate'`` (procest)
  written for any step response. Collinear columns (a first-order lag has a one-dimensional
  free response) are left to the rank-revealing linear solve.
* :func:`offset_response` ``s`` - the response to a constant unit input from the window
  start: for an integrating structure it is the drift of an unknown input balance point
  ``u0``, so ``c_u = -K (u0 - u_ref)`` estimates ``u0`` jointly.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from ..memory import CHUNK
from ..models import PARAMETERS, STRUCTURES, ProcessModel, Structure
from ..record import infer_sample_time
from .engine import convolved, pulse_length, pulse_response, simulate
from .zoh import discrete_poles

#: Poles of a rational model up to this order are filtered recursively (beyond it an
#: expanded polynomial with poles near 1 loses precision, see pipeline.simulate).
MAX_IIR_ORDER = 2


def step_delayed(spec: Structure, p: dict[str, float], tt: np.ndarray) -> np.ndarray:
    """Unit-gain step response with the dead time ``p["delay"]`` at times ``tt`` (0 before
    the dead time), right-continuous at it as :meth:`pipeline.models.ProcessModel.
    unit_step` (a lead-lag's jump is seen at the sample where the delayed step arrives,
    also at a dead time of 0 or a whole number of samples)."""
    tt = np.asarray(tt, dtype=np.float64)
    delay = float(p.get("delay", 0.0))
    s = tt - delay
    out = np.zeros_like(s)
    eps = 1e-12 * max(1.0, abs(delay), float(np.max(np.abs(tt))) if tt.size else 0.0)
    pos = s >= -eps
    if pos.any():
        out[pos] = spec.step(p, np.maximum(s[pos], 0.0))
    return out


def uniform_step(t: np.ndarray) -> float | None:
    """The sample time of ``t`` if the grid is uniform (the simulator's tolerance)."""
    return infer_sample_time(np.asarray(t, dtype=np.float64), rel_tol=1e-4)


def forced_response(structure: str, p: dict[str, float], t: np.ndarray, du: np.ndarray,
                    dt: float | None = None, *, u0: float = 0.0,
                    minus: np.ndarray | None = None) -> np.ndarray:
    """Unit-gain response from rest to the held input ``du``, a deviation from ``u0``
    (see the module docstring; ``u0`` is subtracted chunk by chunk, so a caller can give
    the measured input of a long record as it is, without making its deviation); ``dt``
    is the uniform sample time (None: found from ``t``, irregular grids are superposed).
    With ``minus``, the response less ``minus``, written into ``minus``'s array (a long
    record's filter subtracts it chunk by chunk: no second record-long array); the same
    numbers as ``np.subtract(response, minus)``."""
    spec = STRUCTURES[structure]
    n = du.size
    dt = uniform_step(t) if dt is None and n else dt
    q = {**p, "K": 1.0}
    iir = None if dt is None or n == 0 else _iir(spec, q, dt)
    if n > CHUNK and iir is not None:
        return _filtered(*iir, du, u0, minus)
    x = _response(structure, q, t, du, dt, u0, iir)
    return x if minus is None else np.subtract(x, minus, out=minus)


def _response(structure: str, q: dict[str, float], t: np.ndarray, du: np.ndarray,
              dt: float | None, u0: float, iir) -> np.ndarray:
    """:func:`forced_response` of a unit-gain model ``q`` other than a long record's
    recursive filter."""
    n = du.size
    if n == 0:
        return np.empty(0)
    if dt is not None and iir is None:  # the exact pulse response, convolved
        m = ProcessModel(structure, q)
        return convolved(pulse_response(m, dt, pulse_length(m, dt, n)), du, u0)
    if u0:
        du = du - u0
    if dt is None:
        return simulate(ProcessModel(structure, q), t, du, 0.0, 0.0)
    b, a, lag = iir
    if lag >= n:
        return np.zeros(n)
    x = signal.lfilter(b, a, du[: n - lag])
    return np.concatenate([np.zeros(lag), x]) if lag else x


def _filtered(b: np.ndarray, a: np.ndarray, lag: int, u: np.ndarray, u0: float,
              minus: np.ndarray | None = None) -> np.ndarray:
    """``lfilter(b, a, u - u0)`` delayed by ``lag`` samples (zeros before), filtered
    :data:`pipeline.memory.CHUNK` samples at a time into the one output array (the filter's
    state carried from chunk to chunk: the same output to the bit), so that the
    record-long input deviation, the filter's output and its copy shifted by the dead time
    (three 80 MB arrays at 10 M samples) are one output array; with ``minus`` that array
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


def _iir(spec: Structure, p: dict[str, float], dt: float
         ) -> tuple[np.ndarray, np.ndarray, int] | None:
    """``(b, a, lag)`` of the exact ZOH pulse response as a recursive filter after ``lag``
    samples of pure dead time, or None when the model is not rational of order <=
    :data:`MAX_IIR_ORDER`."""
    a = _pole_polynomial(spec, p, dt)
    if a is None:
        return None
    order = a.size - 1
    # h obeys the pole recursion from sample ceil(delay/dt) + 1 on; the head before that
    # (and `order` samples more) is computed exactly from the step response
    delay = float(p.get("delay", 0.0))
    head = int(math.ceil(delay / dt - 1e-9)) + order + 2
    k = np.arange(head, dtype=np.float64) * dt
    # step_delayed(spec, p, k) and its differences (np.diff with 0 prepended), written
    # out: the same arithmetic without the generic checks, on every residual evaluation
    # of a refinement (k >= 0 ascending, so its largest magnitude is its last)
    s = k - delay
    eps = 1e-12 * max(1.0, abs(delay), float(k[-1]))
    h = np.zeros_like(s)
    pos = s >= -eps
    if pos.any():
        h[pos] = spec.step(p, np.maximum(s[pos], 0.0))
    h[1:] -= h[:-1].copy()
    b = np.convolve(h, a)[:head]
    nz = np.flatnonzero(b)
    lag = int(nz[0]) if nz.size else head
    return b[lag:], a, lag


def _denominator(spec: Structure, p: dict[str, float]) -> list[float] | None:
    """The denominator in descending powers of s, leading zeros dropped (None: not
    rational)."""
    nd = spec.num_den(p)
    if nd is None:
        return None
    den = [float(c) for c in nd[1]]
    while den and den[0] == 0.0:
        den.pop(0)
    return den


def rational_order(spec: Structure, p: dict[str, float]) -> int | None:
    """Degree of the denominator (None: not rational). The degree of every structure of the
    table depends on its dimensionless parameters only (the order n), the time constants
    scale the coefficients; so it is cached on those (an integer-order equal-lag
    denominator is expensive to expand)."""
    names = _DIMENSIONLESS.get(spec.name)
    if names is None:
        names = _DIMENSIONLESS[spec.name] = tuple(
            k for k in spec.dynamics if k in PARAMETERS and PARAMETERS[k].kind ==
            "dimensionless")
    key = (spec.name, tuple((k, float(p[k])) for k in names))
    if key not in _ORDERS:
        den = _denominator(spec, p)
        if len(_ORDERS) > 4096:
            _ORDERS.clear()
        _ORDERS[key] = None if den is None else len(den) - 1
    return _ORDERS[key]


_ORDERS: dict[tuple, int | None] = {}
_DIMENSIONLESS: dict[str, tuple[str, ...]] = {}  # a structure's dimensionless parameters


def _pole_polynomial(spec: Structure, p: dict[str, float], dt: float) -> np.ndarray | None:
    """``[1, a1 (, a2)]``: the polynomial in z^-1 of the discrete poles ``exp(s_i dt)`` of a
    rational model of order 1 or 2 (closed forms; None otherwise)."""
    order = rational_order(spec, p)
    if order is None or not 1 <= order <= MAX_IIR_ORDER:
        return None
    den = _denominator(spec, p)
    if den is None or not 2 <= len(den) <= MAX_IIR_ORDER + 1 or not all(
            math.isfinite(c) for c in den):
        return None
    return discrete_poles(den, dt)


def basis_lags(spec: Structure, p: dict[str, float], n_max: int = 3) -> int:
    """How many free-response columns: the number of poles of a rational model (at most
    ``n_max``), else ``n_max``."""
    order = rational_order(spec, {**p, "K": 1.0})
    if order is None:
        return n_max
    return int(min(max(order, 1), n_max))


def free_basis(structure: str, p: dict[str, float], t_rel: np.ndarray, horizon: float,
               n_max: int = 3) -> np.ndarray:
    """Columns ``S(t' + tau_j) - S(t')`` (``t' = t_rel >= 0``, time since the window start)
    for ``tau_j`` geometrically spread from a quarter to four times the model's time scale
    (the dead time added; ``horizon`` when the time scale is not finite or zero)."""
    return np.column_stack(list(each_free_column(structure, p, t_rel, horizon, n_max)))


def each_free_column(structure: str, p: dict[str, float], t_rel: np.ndarray,
                     horizon: float, n_max: int = 3):
    """:func:`free_basis`' columns one at a time (a span-long design's rows are made a
    column at a time, :meth:`pipeline.refine.problem.Problem.rows_of`)."""
    spec = STRUCTURES[structure]
    q = {**p, "K": 1.0}
    m = basis_lags(spec, q, n_max)
    ts = float(spec.time_scale(q))
    if not math.isfinite(ts) or ts <= 0:
        ts = horizon
    ts += float(q.get("delay", 0.0))
    taus = ts * np.geomspace(0.25, 4.0, m) if m > 1 else np.array([ts])
    s_now = step_delayed(spec, q, t_rel)
    for tau in taus:
        yield step_delayed(spec, q, t_rel + tau) - s_now


def offset_response(structure: str, p: dict[str, float], t_rel: np.ndarray) -> np.ndarray:
    """Response to a constant unit input from the window start (the unknown input balance
    point of an integrating structure)."""
    return step_delayed(STRUCTURES[structure], {**p, "K": 1.0}, t_rel)


def model_response(model: ProcessModel, t, u, u0: float, y0: float) -> np.ndarray:
    """:func:`pipeline.simulation.simulate` (same definition: from rest at ``(u0, y0)``,
    input held) through :func:`forced_response`: closed-form discrete poles instead of a
    matrix exponential per call."""
    t = np.asarray(t, dtype=np.float64)
    if t.size < 2:
        return np.full(t.size, float(y0))
    du = np.asarray(u, dtype=np.float64) - float(u0)
    return float(y0) + model.K * forced_response(model.structure, dict(model.params), t, du)
