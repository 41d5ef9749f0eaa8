"""The search space of a refinement and its candidate starts (:mod:`pipeline.refine`).

* :func:`search_space` - the nonlinear parameters on log scale where they are positive,
  linear (scaled by the window) otherwise, inside practical bounds: a time constant far
  below the sample time or far above the window is not determined by the data;
* :func:`candidate_starts` - the graphical methods' models of the structure as they are,
  and templates of the structure (:func:`templates`) scaled to every time scale and dead
  time the graphical models read, and to the window's own time scales, for a structure
  no graphical model resembles. Written over the structure table (its step response,
  bounds and time scale) and the parameter table's unit kinds, so a new structure gets
  starts with no edit here;
* :func:`multistart` - the search itself: the best-ranked start to convergence, kept
  where its residual is the noise (:func:`noise_like`); else a few trust-region
  iterations from each of the best distinct starts, then the best of them to
  convergence (``scipy.optimize.least_squares``, trust-region reflective, bounded); when
  that ends at a time scale far beyond the data (:func:`far_bound`), more starts are
  tried.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ..models import PARAMETERS, STRUCTURES, ProcessModel

#: Iterations of the pilot runs from each start (the best one then runs to convergence).
PILOT_NFEV = 3
#: Starts count as distinct when a log-scale parameter differs by this (a factor 1.65) or a
#: linear one by this share of the window.
DISTINCT_LOG, DISTINCT_LINEAR = 0.5, 0.05
#: Relative tolerances of the search (cost and step): far below a noise-limited precision.
FTOL = 1e-5
#: A time constant within this share of its search range of the upper bound (a hundred
#: spans), or a frequency as near its lower bound, is at the bound (:func:`far_bound`).
FAR_BOUND = 1e-3
#: When the best run ends there, this many times ``n_starts`` more distinct candidates at
#: most are tried.
MORE_STARTS = 3

#: A converged run whose residual is within this factor of the noise (:func:`noise_like`)
#: is in the right basin: no other start is tried.
BASIN_RATIO = 1.2

#: Bytes of residual vectors one search keeps to reuse (:func:`multistart`): a one-event
#: search's hundreds of evaluations of at most 600 rows are all kept; a fit over many
#: events has :data:`pipeline.refine.joint.ROWS_PER_EVENT` rows per event, and keeping all
#: its residuals would grow with the events times the evaluations.
MEMO_BYTES = 32 << 20

#: Start values of dimensionless parameters (templates; the time parameters are scaled).
DIMENSIONLESS_STARTS: dict[str, tuple[float, ...]] = {"zeta": (0.4, 1.0, 2.0),
                                                      "n": (2.0, 4.0)}


@dataclass(frozen=True)
class Space:
    """The searched parameters (``names``), which are on log scale, the scale of the
    linear ones, and the bounds, all in search coordinates ``z``; ``floor`` (in parameter
    units) is where a linear parameter whose search range reaches below it is held (the
    dead time: see :func:`search_space`)."""

    names: tuple[str, ...]
    log: np.ndarray
    scale: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    floor: np.ndarray

    def to_z(self, p: Mapping[str, float]) -> np.ndarray:
        v = np.array([float(p[n]) for n in self.names])
        z = np.where(self.log, np.log(np.maximum(np.abs(v), 1e-300)), v / self.scale)
        return np.clip(z, self.lo + 1e-9 * (self.hi - self.lo), self.hi - 1e-9 *
                       (self.hi - self.lo))

    def from_z(self, z: np.ndarray) -> dict[str, float]:
        v = np.maximum(np.where(self.log, np.exp(z), z * self.scale), self.floor)
        return {n: float(x) for n, x in zip(self.names, v, strict=True)}

    @property
    def lo_z(self) -> np.ndarray:
        """The lowest search coordinate that is not held at the floor."""
        return np.maximum(self.lo, np.where(self.log, -np.inf, self.floor / self.scale))


def search_space(structure: str, names: Sequence[str], dt: float, span: float) -> Space:
    """Log scale for positive parameters; practical bounds from the sample time and the
    span (a time constant far below the sample time or far above the record is not
    determined by the data), inside the structure table's bounds. For a structure whose
    step response jumps at its dead time (a lead-lag: :func:`jumps`) the dead time's range
    starts half a sample below 0, where it is held at 0 (``floor``): the jump is seen at
    the sample where it arrives, so the cost at a dead time of 0 is reached only from
    below, never from inside the bound (elsewhere a flat stretch would trap the search)."""
    spec = STRUCTURES[structure]
    below = 0.5 * dt if jumps(structure) else 0.0
    log, scale, lo, hi, floor = [], [], [], [], []
    for name in names:
        b_lo, b_hi = spec.bounds.get(name, (-math.inf, math.inf))
        kind = PARAMETERS[name].kind if name in PARAMETERS else "dimensionless"
        floor.append(max(b_lo, 0.0) if name == "delay" else -math.inf)
        if name == "delay":
            rng = (max(b_lo, 0.0) - below, min(b_hi, 0.9 * span))
        elif kind == "time":
            rng = (max(b_lo, dt / 100) if b_lo >= 0 else max(b_lo, -100 * span),
                   min(b_hi, 100 * span))
        elif kind == "frequency":
            rng = (max(b_lo, 1 / (100 * span)), min(b_hi, 100 / dt))
        else:
            rng = (max(b_lo, 1e-3) if b_lo >= 0 else max(b_lo, -1e3), min(b_hi, 1e3))
        is_log = name != "delay" and b_lo >= 0
        s = span if kind == "time" else 1.0
        log.append(is_log)
        scale.append(s)
        lo.append(math.log(rng[0]) if is_log else rng[0] / s)
        hi.append(math.log(rng[1]) if is_log else rng[1] / s)
    return Space(tuple(names), np.array(log, bool), np.array(scale), np.array(lo),
                 np.array(hi), np.array(floor))


def jumps(structure: str) -> bool:
    """Whether the structure's step response jumps at the dead time (a numerator of the
    denominator's degree: direct feedthrough), judged on its first template."""
    nd = STRUCTURES[structure].num_den(templates(structure, 1.0, 0.0)[0])
    return nd is not None and len(nd[0]) == len(nd[1]) and nd[0][0] != 0


def candidate_starts(structure: str, models: Sequence[ProcessModel], horizon: float,
                     delays: Sequence[float] = ()) -> list[dict[str, float]]:
    """Starts for a structure: every given model of that structure as it is, and for each
    distinct (time scale, dead time) among all given models, and the time scales
    ``horizon / 20`` and ``horizon / 5`` of the window itself (a structure no given model
    resembles), the templates of the structure scaled to it (see :func:`templates`), with
    that dead time and with half the time scale more. ``delays``: dead times read off the
    data (:func:`pipeline.refine.event.band_exit`), combined with every time scale: a
    response that jumps at its dead time (a lead-lag) has a cost that is discontinuous
    in the dead time at every sample, which the search cannot cross."""
    out = [dict(m.params) for m in models if m.structure == structure]
    out += nested_starts(structure, models)
    scales = {(_round2(m.time_scale), _round2(m.delay)) for m in models
              if math.isfinite(m.time_scale) and m.time_scale > 0}
    scales |= {(horizon / 20, 0.0), (horizon / 5, 0.0)}
    scales |= {(tau, float(d)) for tau, _ in list(scales) for d in delays}
    for tau, delay in sorted(scales):
        for d in (delay, delay + tau / 2):  # a dead time the readings missed
            out.extend(templates(structure, tau, d))
    return out


#: The value at which a parameter leaves a structure's nested one: a zero's time
#: constant of 0 makes two lags and a zero two lags, a lead-lag a first order.
NESTING_VALUES = {"Tz": 0.0}


def nested_starts(structure: str, models: Sequence[ProcessModel]) -> list[dict[str, float]]:
    """The optimum of every nested structure among ``models`` as a start of
    ``structure`` (its parameters, the others at :data:`NESTING_VALUES`): the larger
    structure can then fit no worse than the one it contains. Without it, on a first-order
    plant logged with fresh noise, ``lsq_zero_two_lags`` ended in a slow creep basin (K 2.88,
    Tz 1177 s, T1 1632 s; MSE 0.044285) where ``lsq_two_lags`` had K 2.09, T1 5.10 s
    (MSE 0.044181), and the gate called the move of its lags a regression."""
    names = set(STRUCTURES[structure].params)
    out = []
    for m in models:
        extra = names - set(m.params)
        if m.structure != structure and set(m.params) < names \
                and extra <= set(NESTING_VALUES):
            out.append({**dict(m.params), **{n: NESTING_VALUES[n] for n in extra}})
    return out


def _round2(v: float) -> float:
    """Two significant digits (readings of one event that agree give one template set)."""
    return float(f"{v:.2g}") if v else 0.0


def templates(structure: str, tau: float, delay: float) -> list[dict[str, float]]:
    """Parameter sets of ``structure`` with time scale ``tau`` and dead time ``delay``:
    each combination of the :data:`DIMENSIONLESS_STARTS`, time parameters equal or spread
    (each a quarter, or four times, the one before; a time parameter that may be negative,
    a zero's, also with the opposite sign), frequencies reciprocal to the time scale."""
    spec = STRUCTURES[structure]
    kinds = {n: PARAMETERS[n].kind if n in PARAMETERS else "dimensionless"
             for n in spec.dynamics}
    dimless = [n for n, k in kinds.items() if k == "dimensionless"]
    times = [n for n, k in kinds.items() if k == "time"]
    signed = [n for n in times if spec.bounds.get(n, (-math.inf, 0.0))[0] < 0]
    choices = [DIMENSIONLESS_STARTS.get(n, (_mid(spec.bounds.get(n)),)) for n in dimless]
    spreads = (1.0, 0.25, 4.0) if len(times) > 1 else (1.0,)
    out = []
    for values, spread, sign in itertools.product(itertools.product(*choices), spreads,
                                                  (1.0, -1.0) if signed else (1.0,)):
        p = {"K": 1.0, "delay": delay, **dict(zip(dimless, values, strict=True))}
        p.update({n: spread**i * (sign if n in signed else 1.0) for i, n in enumerate(times)})
        p.update({n: 1.0 for n, k in kinds.items() if k == "frequency"})
        ts = float(spec.time_scale(p))
        f = tau / ts if math.isfinite(ts) and ts > 0 else 1.0
        p.update({n: v * (f if kinds.get(n) == "time" else 1 / f if kinds.get(n) ==
                          "frequency" else 1.0) for n, v in p.items() if n in kinds})
        out.append(p)
    return out


def _mid(b: tuple[float, float] | None) -> float:
    lo, hi = b or (0.0, math.inf)
    if math.isfinite(lo) and math.isfinite(hi):
        return math.sqrt(lo * hi) if lo > 0 else (lo + hi) / 2
    return max(lo, 1.0) if math.isfinite(lo) else 1.0


def defaults(names: Sequence[str]) -> dict[str, float]:
    """Values for parameters a start does not give (dead time 0, the first template)."""
    return {n: 0.0 if n == "delay" else DIMENSIONLESS_STARTS.get(n, (1.0,))[0] for n in names}


def snap(space: Space, p: Mapping[str, float]) -> dict[str, float]:
    """Parameters within 1e-6 of the search range from a bound put on it (a dead time of
    1e-12 s is a dead time of 0 the search approached from above)."""
    out = dict(p)
    if not space.names:
        return out
    z = space.to_z(p)
    tol = 1e-6 * (space.hi - space.lo)
    for i, n in enumerate(space.names):
        for b in (space.lo_z[i], space.hi[i]):
            if abs(z[i] - b) <= tol[i]:
                out[n] = float(math.exp(b) if space.log[i] else b * space.scale[i])
    return out


@dataclass(frozen=True)
class Run:
    """The best least-squares run: its parameters, cost (half the sum of squares), the
    residual evaluations it took and the number of starts tried."""

    params: dict[str, float]
    cost: float
    nfev: int
    runs: int


def multistart(fun: Callable[[np.ndarray], np.ndarray], space: Space,
               starts: Sequence[Mapping[str, float]], n_starts: int, max_nfev: int) -> Run:
    """Minimise ``|fun(z)|^2`` over ``space`` from the ``n_starts`` best distinct
    ``starts`` (parameters a start lacks: :func:`defaults`; ``n_starts`` < 1: all of
    them): the best-ranked one to convergence, the answer where its residual is the noise
    (:func:`noise_like`) and no time scale is at a far bound; else :data:`PILOT_NFEV`
    iterations from each of them, then the best run to convergence; when that ends at a
    time scale far beyond the data (:func:`far_bound`), up to :data:`MORE_STARTS` times
    as many more are piloted and every pilot run to convergence; the lowest cost of all
    (the first run's too) kept. ``fun`` returns the residual vector at search
    coordinates ``z``."""
    # every run starts where a residual was already evaluated (a candidate's ranking, the
    # pilot's last point), and least_squares evaluates it again: the same z gives the
    # same residual, so it is kept (a read-only view) and not simulated twice; the
    # residuals of one search are kept up to MEMO_BYTES, the least recently used dropped
    # beyond (a dropped one is simulated again if asked for: the same numbers)
    seen_r: dict[bytes, np.ndarray] = {}
    held = 0

    def safe(z):
        nonlocal held
        key = np.asarray(z, np.float64).tobytes()
        r = seen_r.pop(key, None)
        if r is not None:
            seen_r[key] = r  # the most recently used now (dicts keep insertion order)
        else:
            r = fun(z)
            r = r.view() if np.all(np.isfinite(r)) else np.full(r.size, 1e150)
            r.setflags(write=False)
            seen_r[key] = r
            held += r.nbytes
            while held > MEMO_BYTES and len(seen_r) > 1:
                held -= seen_r.pop(next(iter(seen_r))).nbytes
        return r

    tol = np.where(space.log, DISTINCT_LOG, DISTINCT_LINEAR)
    seen: dict[tuple, np.ndarray] = {}  # starts within a tenth of the distinct step: one
    for s in starts:
        try:
            z = space.to_z({**defaults(space.names), **s})
        except (KeyError, ValueError):
            continue
        seen.setdefault(tuple(np.round(z / (0.1 * tol)).astype(int)), z)
    if not seen:
        seen = {(): space.to_z(defaults(space.names))}
    cands = sorted(((0.5 * float(np.sum(safe(z) ** 2)), k, z) for k, z in seen.items()),
                   key=lambda c: c[0])
    def distinct(limit: int | None, chosen: list[np.ndarray]) -> list[np.ndarray]:
        """The best-ranked candidates distinct from ``chosen`` and each other."""
        out: list[np.ndarray] = []
        for _, _, z in cands:
            if limit is not None and len(chosen) + len(out) == limit:
                break
            if all(np.max(np.abs(z - c) / tol) > 1.0 for c in chosen + out):
                out.append(z)
        return out

    chosen = distinct(n_starts if n_starts > 0 else None, [])
    nfev = len(cands)

    def run(z0, limit):
        nonlocal nfev
        res = least_squares(safe, z0, bounds=(space.lo, space.hi), method="trf",
                            max_nfev=limit, x_scale=1.0, ftol=FTOL, xtol=FTOL)
        nfev += res.nfev + (res.njev or 0) * len(z0)
        return res

    # the best-ranked start to convergence first: where it ends in a basin whose residual
    # is the noise (:func:`noise_like`) and not at a far bound, the other starts are not
    # tried (on a first-order event of 5,000 samples the pilots were 44 % of the fit's
    # CPU); else, as before, a few iterations from each start (the first one's are
    # remembered residuals), the best run to convergence, and the first run kept where
    # it is lower still
    first = run(chosen[0], max_nfev) if len(chosen) > 1 else None
    if first is not None and first.status != 0 and not far_bound(space, first.x) \
            and noise_like(first.fun):
        return Run(space.from_z(first.x), float(first.cost), nfev, 1)
    runs = sorted(([run(z0, PILOT_NFEV) for z0 in chosen] if len(chosen) > 1 else []),
                  key=lambda r: r.cost)
    best = runs[0] if runs else None
    if best is None or best.status == 0:  # 0: stopped by max_nfev
        best = run(chosen[0] if best is None else best.x, max_nfev)
    if runs and far_bound(space, best.x):
        # the best pilot ran off to a time scale far beyond the data (a slow pole-zero
        # pair creeping past the window, fitting a drift in the noise): more distinct
        # candidates are piloted, each pilot run to convergence, the lowest cost kept (on
        # a one-lag plant a zero-two-lags fit from the 3 best starts ended at a lag of
        # 3,700 s on a 37 s window; from 12 starts at the plant's 5 s lag, cost lower)
        more = distinct(len(chosen) * (1 + MORE_STARTS), chosen)
        for other in sorted(runs[1:] + [run(z0, PILOT_NFEV) for z0 in more],
                            key=lambda r: r.cost):
            alt = run(other.x, max_nfev) if other.status == 0 else other
            if alt.cost < best.cost:
                best = alt
        chosen += more
    if first is not None and first.cost < best.cost:
        best = first
    return Run(space.from_z(best.x), float(best.cost), nfev, len(chosen))


def noise_like(r: np.ndarray) -> bool:
    """Whether the residual ``r`` is within :data:`BASIN_RATIO` of the white noise its
    differences show: its mean square at most that many times half the mean square of
    its first differences (white noise's variance; a misfit's slow pattern adds to the
    first, hardly to the second). Coloured noise reads as misfit: the search then tries
    every start, as it always did."""
    r = np.asarray(r, np.float64)
    if r.size < 3:
        return False
    d = np.diff(r)
    return float(r @ r) / r.size <= BASIN_RATIO * 0.5 * float(d @ d) / d.size


def far_bound(space: Space, z: np.ndarray) -> bool:
    """Whether ``z`` has a positive time constant at its upper search bound (a hundred
    spans) or a frequency at its lower one (a period of a hundred spans): a time scale
    the data cannot have determined. A damping at its bound is an overdamped second
    order, a first-order response: no sign of a wrong basin."""
    margin = FAR_BOUND * (space.hi - space.lo)
    kind = np.array([PARAMETERS[n].kind if n in PARAMETERS else "" for n in space.names])
    far = ((kind == "time") & (z >= space.hi - margin)) | \
        ((kind == "frequency") & (z <= space.lo + margin))
    return bool(np.any(far & space.log))
