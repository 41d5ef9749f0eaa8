"""Exact zero-order-hold discretisation of the model structures, in closed form.

:func:`filter_of` gives the recursive filter ``(b, a, lag)`` of a rational structure of
order at most two (every structure of :data:`pipeline.models.STRUCTURES` but the long and
the non-integer equal-lag chains): its exact ZOH pulse response
``h[k] = S(k dt - delay) - S((k-1) dt - delay)`` obeys the recursion of the discrete poles
``z_i = exp(s_i dt)`` once the dead time has passed, so the numerator is the exactly
computed head of ``h`` convolved with the pole polynomial: exact for fractional dead
times too (the modified z-transform; Franklin, Powell, Workman, Digital Control of
Dynamic Systems, 3rd ed., sec. 4.3.4). The poles come in closed form (first order
``a = exp(-dt/T)``; two real lags; a complex pair ``2 e^{-zeta wn dt} cos(wd dt)``; an
integrator's pole at 1), the head from the closed-form step response
(:func:`pipeline.models.delayed_step`): no matrix exponential per call
(``scipy.signal.cont2discrete`` costs several times a bare ``lfilter`` on an event).
:func:`zoh_filter` is the same filter of a model, cached (a model simulated again: a fit
scored, validated, plotted); a refinement's search asks :func:`filter_of` for new
parameters every time, where a cache would only cost.

:func:`memory` is how many samples back a model's output still depends on the input (its
pulse response decayed below double precision), so a simulation that is scored only late
in a record can start that far before (:mod:`pipeline.validate`).

:func:`state_space` and :func:`transitions` serve irregular time grids: the exact ZOH
transition of each distinct interval (intervals grouped within :data:`STEP_REL_TOL`), all
distinct intervals at once: in closed form from the eigen-decomposition of the state
matrix when its poles are distinct, else one batched matrix exponential.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import linalg, signal
from scipy.special import gammainccinv

from ..models import PARAMETERS, STRUCTURES, ProcessModel, Structure, delayed_step

#: Poles of a rational model up to this order are filtered recursively (beyond it an
#: expanded polynomial with poles near 1 is numerically useless: long equal-lag chains go
#: through the pulse response, :mod:`pipeline.simulation.engine`).
MAX_IIR_ORDER = 2
#: The tail of the pulse response beyond :func:`memory` (relative to the gain).
MEMORY_TOL = 1e-17
#: Irregular grids: intervals that agree to this relative tolerance share one
#: discretisation (time stamps parsed from text jitter by a few ulps; an error of 1e-12
#: in an interval is far below any logged signal's resolution).
STEP_REL_TOL = 1e-12


@dataclass(frozen=True)
class Filter:
    """``x[k] = lfilter(b, a, du)[k - lag]`` (0 before ``lag``): the exact ZOH response
    of a unit-gain model to the held input ``du``."""

    b: np.ndarray
    a: np.ndarray
    lag: int


def filter_of(structure: str, p: Mapping[str, float], dt: float) -> Filter | None:
    """The exact ZOH filter of the unit-gain ``structure`` with parameters ``p`` at sample
    time ``dt`` (see the module docstring), or None when the model is not rational of
    order 1 to :data:`MAX_IIR_ORDER`."""
    spec = STRUCTURES[structure]
    q = {**p, "K": 1.0}
    a = pole_polynomial(spec, q, dt)
    if a is None:
        return None
    order = a.size - 1
    # h obeys the pole recursion from sample ceil(delay/dt) + 1 on; the head before that
    # (and `order` samples more) is computed exactly from the step response
    delay = float(q.get("delay", 0.0))
    head = int(math.ceil(delay / dt - 1e-9)) + order + 2
    h = delayed_step(spec, q, np.arange(head, dtype=np.float64) * dt)
    h[1:] -= h[:-1].copy()
    b = np.convolve(h, a)[:head]
    nz = np.flatnonzero(b)
    lag = int(nz[0]) if nz.size else head
    return Filter(b[lag:], a, lag)


def zoh_filter(model: ProcessModel, dt: float) -> Filter | None:
    """:func:`filter_of` of ``model`` (unit gain), cached per model and sample time."""
    # the same model object simulated again (a fit scored, plotted, validated): found by
    # identity, which is safe while the cache holds the object (its id cannot be reused);
    # else by its hashable key, whose making costs a sizeable share of a short event's
    # lfilter, which the identity path saves.
    hit = _BY_ID.get((id(model), dt))
    if hit is not None and hit[0] is model:
        return hit[1]
    f = _cached_filter(model_key(model), float(dt))
    if len(_BY_ID) >= 256:
        _BY_ID.clear()
    _BY_ID[(id(model), dt)] = (model, f)
    return f


_BY_ID: dict[tuple[int, float], tuple[ProcessModel, Filter | None]] = {}


def model_key(model: ProcessModel) -> tuple:
    """A hashable key of ``model`` (structure and parameters)."""
    return (model.structure, tuple(sorted((k, float(v)) for k, v in model.params.items())))


@lru_cache(maxsize=4096)
def _cached_filter(key: tuple, dt: float) -> Filter | None:
    f = filter_of(key[0], dict(key[1]), dt)
    if f is not None:
        for arr in (f.a, f.b):
            arr.setflags(write=False)
    return f


def denominator(spec: Structure, p: Mapping[str, float]) -> list[float] | None:
    """The denominator in descending powers of s, leading zeros dropped (None: not
    rational, or not finite)."""
    nd = spec.num_den(p)
    if nd is None:
        return None
    den = [float(c) for c in nd[1]]
    while den and den[0] == 0.0:
        den.pop(0)
    return den if all(math.isfinite(c) for c in den) else None


def rational_order(spec: Structure, p: Mapping[str, float]) -> int | None:
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
        nd = spec.num_den(p)
        den = None if nd is None else [float(c) for c in nd[1]]
        while den and den[0] == 0.0:
            den.pop(0)
        if len(_ORDERS) > 4096:
            _ORDERS.clear()
        _ORDERS[key] = None if den is None else len(den) - 1
    return _ORDERS[key]


_ORDERS: dict[tuple, int | None] = {}
_DIMENSIONLESS: dict[str, tuple[str, ...]] = {}  # a structure's dimensionless parameters


def pole_polynomial(spec: Structure, p: Mapping[str, float], dt: float
                    ) -> np.ndarray | None:
    """``[1, a1 (, a2)]``: the polynomial in z^-1 of the discrete poles ``exp(s_i dt)`` of a
    rational model of order 1 to :data:`MAX_IIR_ORDER` (closed forms; None otherwise)."""
    order = rational_order(spec, p)
    if order is None or not 1 <= order <= MAX_IIR_ORDER:
        return None
    den = denominator(spec, p)
    if den is None or not 2 <= len(den) <= MAX_IIR_ORDER + 1:
        return None
    return discrete_poles(den, dt)


def discrete_poles(den: list[float], dt: float) -> np.ndarray | None:
    """``[1, a1 (, a2)]`` for a continuous denominator of degree 1 or 2 (descending powers
    of s, no leading zero): the poles ``s_i`` map to ``exp(s_i dt)`` (zero-order hold),
    real or a complex pair in closed form; None for another degree."""
    if not 2 <= len(den) <= 3:
        return None
    if len(den) == 2:
        return np.array([1.0, -math.exp(-den[1] / den[0] * dt)])
    b, c = den[1] / den[0], den[2] / den[0]  # s^2 + b s + c
    disc = b * b - 4 * c
    if disc >= 0:
        r = math.sqrt(disc)
        z1, z2 = math.exp((-b + r) / 2 * dt), math.exp((-b - r) / 2 * dt)
        return np.array([1.0, -(z1 + z2), z1 * z2])
    mag = math.exp(-b / 2 * dt)  # complex pair exp((-b/2 +- i w) dt)
    return np.array([1.0, -2 * mag * math.cos(math.sqrt(-disc) / 2 * dt), mag * mag])


def memory(model: ProcessModel, dt: float) -> int | None:
    """Samples after which the model's ZOH pulse response is below :data:`MEMORY_TOL` of
    its gain for good: the output at sample k depends on the input at samples
    ``k - memory .. k`` only. None for an integrating model (it never forgets) or one
    whose decay is unknown."""
    if model.integrating:
        return None
    p = {k: float(v) for k, v in model.params.items()}
    if model.structure == "n_lags":
        if not (p["T"] > 0 and p["n"] > 0):
            return None
        horizon = p["T"] * float(gammainccinv(p["n"], MEMORY_TOL))
    else:
        den = denominator(model.spec, model.params)
        if den is None:
            return None
        poles = np.roots(den)
        if poles.size == 0 or np.any(poles.real >= 0):
            return None
        slow = float(np.max(-1.0 / poles.real))
        # e^{-x} x <= 1e-17 / (1 + |Tz|/slow) covers repeated poles and a zero's weight
        zero = abs(p.get("Tz", 0.0)) / slow
        horizon = slow * (45.0 + math.log1p(zero))
    if not math.isfinite(horizon):
        return None
    return int(math.ceil((horizon + model.delay) / dt)) + 3


# -- irregular grids -----------------------------------------------------------------------

def state_space(model: ProcessModel) -> tuple[np.ndarray, ...] | None:
    """``(A, B, C, D)`` of the rational part (gain included, dead time not), or None (a
    non-integer order n). An equal-lag chain is written as the chain (bidiagonal), not as
    the expanded polynomial."""
    p = {k: float(v) for k, v in model.params.items()}
    if model.structure == "n_lags":
        n = p["n"]
        if not n.is_integer() or n < 1:
            return None
        m = int(n)
        A = (np.eye(m, k=-1) - np.eye(m)) / p["T"]
        B = np.zeros((m, 1))
        B[0, 0] = 1.0 / p["T"]
        C = np.zeros((1, m))
        C[0, -1] = p["K"]
        return A, B, C, np.zeros((1, 1))
    nd = model.num_den()
    if nd is None:
        return None
    with warnings.catch_warnings():
        # a numerator whose leading coefficient is negligible (a lead-lag's zero near 0 s):
        # scipy strips it, which is exact here, and says so on stderr for every simulation
        warnings.simplefilter("ignore", signal.BadCoefficients)
        abcd = signal.tf2ss(*nd)
    return tuple(np.atleast_2d(x) for x in abcd)


def step_groups(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(distinct intervals, index of each interval's group)``: intervals grouped on a
    logarithmic grid of width :data:`STEP_REL_TOL` (represented by the group's centre,
    so each interval is off by at most half the tolerance); zero intervals stay zero."""
    pos = h > 0
    zero = np.iinfo(np.int64).min
    code = np.full(h.size, zero, dtype=np.int64)
    code[pos] = np.rint(np.log(h[pos]) / STEP_REL_TOL).astype(np.int64)
    codes, inverse = np.unique(code, return_inverse=True)
    steps = np.where(codes != zero, np.exp(np.maximum(codes, -10**15) * STEP_REL_TOL), 0.0)
    return steps, inverse.ravel()


def transitions(A: np.ndarray, B: np.ndarray, steps: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Exact ZOH ``(Phi, Gamma)`` for each of the intervals ``steps``: with distinct
    eigenvalues ``A = V diag(l) V^-1`` in closed form, ``Phi = V diag(e^{l h}) V^-1``,
    ``Gamma = V diag(expm1(l h)/l) V^-1 B`` (``h`` for ``l = 0``), vectorised over the
    intervals; otherwise (repeated poles: an equal-lag chain, critical damping) one batched
    matrix exponential of ``[[A, B], [0, 0]] h``, the construction of ``cont2discrete``
    (measured: 3 ms per interval on the shared machine, which made a refinement on an
    irregular grid spend 90 % of its time there)."""
    n, m = A.shape[0], B.shape[1]
    lam, V = np.linalg.eig(A)
    scale = max(float(np.max(np.abs(lam))), 1e-300)
    gaps = np.abs(lam[:, None] - lam[None, :]) + np.eye(n) * scale
    if n == 1 or (float(np.min(gaps)) > 1e-4 * scale and np.linalg.cond(V) < 1e6):
        Vinv = np.linalg.inv(V)
        lh = lam[None, :] * steps[:, None]
        E = np.exp(lh)
        safe = np.where(lam == 0, 1.0, lam)
        F = np.where(lam[None, :] == 0, steps[:, None] + 0j, np.expm1(lh) / safe[None, :])
        Phi = np.einsum("ij,kj,jl->kil", V, E, Vinv).real
        Gam = np.einsum("ij,kj,jl->kil", V, F, Vinv @ B.astype(complex)).real
        return Phi, Gam
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = expm_near(M, steps)
    return E[:, :n, :n], E[:, :n, n:]


#: :func:`expm_near`: the intervals' bins (relative width) and the Taylor series' reach
#: (``||M d||`` at most this) and length (its remainder below 1e-20 there).
NEAR_BIN = 0.01
NEAR_REACH = 0.5
NEAR_TERMS = 20


def expm_near(M: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """``expm(M h)`` for every interval ``h`` in ``steps``: exact, as one batched
    ``scipy.linalg.expm`` would be, at a fraction of its cost when the intervals cluster
    (a logger's jitter: hundreds of distinct intervals near one or two values). Each
    interval is ``b + d`` with ``b`` its bin's centre (bins :data:`NEAR_BIN` wide on a log
    scale): ``expm(M h) = expm(M b) expm(M d)``, the first once per bin, the second by
    its Taylor series while ``||M d|| <= NEAR_REACH`` (the rest by ``expm``). Why: on a
    600-sample jittered log the batched ``expm`` of the repeated-pole structures was 40 %
    of ``identify --events all`` (BENCHMARKS.md, "Jittered time stamps")."""
    k = M.shape[0]
    out = np.empty((steps.size, k, k))
    pos = steps > 0
    out[~pos] = np.eye(k)
    if not np.any(pos):
        return out
    h = steps[pos]
    codes, inverse = np.unique(np.rint(np.log(h) / NEAR_BIN).astype(np.int64),
                               return_inverse=True)
    base = np.exp(codes * NEAR_BIN)
    d = h - base[inverse]
    norm = float(np.linalg.norm(M, 1))
    near = np.abs(d) * norm <= NEAR_REACH
    res = np.empty((h.size, k, k))
    if np.any(near):
        # (M/norm)^j/j! and (d norm)^j: neither overflows whatever ||M|| is
        unit = M / norm if norm > 0 else M
        powers = np.empty((NEAR_TERMS + 1, k, k))
        powers[0] = np.eye(k)
        for j in range(1, NEAR_TERMS + 1):
            powers[j] = powers[j - 1] @ unit / j
        dn = d[near] * (norm if norm > 0 else 1.0)
        coeff = dn[:, None] ** np.arange(NEAR_TERMS + 1)[None, :]
        taylor = np.tensordot(coeff, powers, axes=(1, 0))
        eb = linalg.expm(M[None, :, :] * base[:, None, None])
        res[near] = eb[inverse[near]] @ taylor
    if not np.all(near):
        res[~near] = linalg.expm(M[None, :, :] * h[~near, None, None])
    out[pos] = res
    return out
