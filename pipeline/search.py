"""The search space of a refinement and its candidate starts (:mod:`pipeline.refine`).

* :func:`search_space` - the nonlinear parameters on log scale where they are positive,
  linear (scaled by the window) otherwise, inside practical bounds: a time constant far
  below the sample time or far above the window is not determined by the data;
* :func:`candidate_starts` - the graphical methods' models of the structure as they are,
  and templates of the structure (:func:`templates`) scaled to every time scale and dead
  time the graphical models read, and to the window's own time scales, for a structure
  no graphical model resembles. Written over the structure table (its step response,
  bounds and time scale) and the parameter table's unit kinds, so a new structure gets
  starts with no edit here.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .models import PARAMETERS, STRUCTURES, ProcessModel

#: Start values of dimensionless parameters (templates; the time parameters are scaled).
DIMENSIONLESS_STARTS: dict[str, tuple[float, ...]] = {"zeta": (0.4, 1.0, 2.0),
                                                      "n": (2.0, 4.0)}


@dataclass(frozen=True)
class Space:
    """The searched parameters (``names``), which are on log scale, the scale of the
    linear ones, and the bounds, all in search coordinates ``z``."""

    names: tuple[str, ...]
    log: np.ndarray
    scale: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    def to_z(self, p: Mapping[str, float]) -> np.ndarray:
        v = np.array([float(p[n]) for n in self.names])
        z = np.where(self.log, np.log(np.maximum(np.abs(v), 1e-300)), v / self.scale)
        return np.clip(z, self.lo + 1e-9 * (self.hi - self.lo), self.hi - 1e-9 *
                       (self.hi - self.lo))

    def from_z(self, z: np.ndarray) -> dict[str, float]:
        v = np.where(self.log, np.exp(z), z * self.scale)
        return {n: float(x) for n, x in zip(self.names, v, strict=True)}


def search_space(structure: str, names: Sequence[str], dt: float, span: float) -> Space:
    """Log scale for positive parameters; practical bounds from the sample time and the
    span (a time constant far below the sample time or far above the record is not
    determined by the data), inside the structure table's bounds."""
    spec = STRUCTURES[structure]
    log, scale, lo, hi = [], [], [], []
    for name in names:
        b_lo, b_hi = spec.bounds.get(name, (-math.inf, math.inf))
        kind = PARAMETERS[name].kind if name in PARAMETERS else "dimensionless"
        if name == "delay":
            rng = (max(b_lo, 0.0), min(b_hi, 0.9 * span))
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
                  np.array(hi))


def candidate_starts(structure: str, models: Sequence[ProcessModel], horizon: float
                     ) -> list[dict[str, float]]:
    """Starts for a structure: every given model of that structure as it is, and for each
    distinct (time scale, dead time) among all given models, and the time scales
    ``horizon / 20`` and ``horizon / 5`` of the window itself (a structure no given model
    resembles), the templates of the structure scaled to it (see :func:`templates`), with
    that dead time and with half the time scale more."""
    out = [dict(m.params) for m in models if m.structure == structure]
    scales = {(_round2(m.time_scale), _round2(m.delay)) for m in models
              if math.isfinite(m.time_scale) and m.time_scale > 0}
    scales |= {(horizon / 20, 0.0), (horizon / 5, 0.0)}
    for tau, delay in sorted(scales):
        for d in (delay, delay + tau / 2):  # a dead time the readings missed
            out.extend(templates(structure, tau, d))
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
        for b in (space.lo[i], space.hi[i]):
            if abs(z[i] - b) <= tol[i]:
                out[n] = float(math.exp(b) if space.log[i] else b * space.scale[i])
    return out
