"""The tuned loop over the model's uncertainty: the worst case of the sensitivity peak.

The parameter sets the data allow are the corners of the 95 % box (every parameter with
an interval at either end; Skogestad & Postlethwaite, *Multivariable Feedback Control*,
2nd ed. 2005, Section 7.4: parametric uncertainty, whose worst case often lies at a
vertex) and draws from the refinement's parameter covariance (correlations included:
:meth:`pipeline.fit.ParameterCovariance.draws`), clipped to the structure's bounds, with
the nominal model first. The fixed controller is checked on each: Ms and closed-loop
stability (:func:`pipeline.tuning.margins.sensitivity_peaks`, exact dead time).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..fit import ParameterCovariance
from ..models import STRUCTURES, ProcessModel
from .controller import Controller
from .margins import sensitivity_peaks
from .plant import batch_response, rhp_poles

#: Draws from the covariance beside the box corners (fixed seed: the same sets each run).
N_DRAWS = 200
#: The box's corners are used while there are at most this many interval parameters.
MAX_CORNER_PARAMS = 6


@dataclass(frozen=True)
class WorstCase:
    """The controller on every parameter set: the largest ``ms`` (``inf`` when a set is
    unstable), the share of stable sets, how many sets, and the worst set's parameters."""

    ms: float
    stable_fraction: float
    n_sets: int
    params: dict[str, float]
    #: how many of the box's corners and of the other sets (covariance draws) are unstable
    n_corners: int = 0
    unstable_corners: int = 0
    unstable_draws: int = 0

    @property
    def stable(self) -> bool:
        return self.stable_fraction == 1.0


def _clip(structure: str, p: dict[str, float]) -> dict[str, float]:
    bounds = STRUCTURES[structure].bounds
    out = {}
    for k, v in p.items():
        lo, hi = bounds.get(k, (-math.inf, math.inf))
        # a lag at its bound 0 would be no lag: keep it a hair inside
        lo = max(lo, 1e-12 * abs(v)) if lo == 0.0 and k != "delay" else lo
        out[k] = float(min(max(v, lo), hi))
    return out


def parameter_sets(model: ProcessModel, ci95: Mapping[str, tuple[float, float]],
                   covariance: ParameterCovariance | None = None, n_draws: int = N_DRAWS,
                   seed: int = 0) -> list[dict[str, float]]:
    """The nominal parameters, the corners of the 95 % box of ``ci95`` and ``n_draws``
    draws of ``covariance`` (each completed with the nominal values, clipped to the
    structure's bounds). Intervals that are not finite are left at the nominal value."""
    nominal = {k: float(v) for k, v in model.params.items()}
    nominal.setdefault("delay", 0.0)
    sets = [nominal]
    spans = _spans(nominal, ci95)
    if n_corners(model, ci95):
        names = list(spans)
        for corner in itertools.product(*(spans[k] for k in names)):
            sets.append(_clip(model.structure, {**nominal, **dict(zip(names, corner,
                                                                      strict=True))}))
    if covariance is not None and n_draws > 0:
        for d in covariance.draws(n_draws, seed=seed):
            sets.append(_clip(model.structure, {**nominal, **{
                k: v for k, v in d.items() if k in nominal and math.isfinite(v)}}))
    return sets


def _spans(nominal: Mapping[str, float], ci95: Mapping[str, tuple[float, float]]
           ) -> dict[str, tuple[float, float]]:
    return {k: (float(lo), float(hi)) for k, (lo, hi) in ci95.items()
            if k in nominal and math.isfinite(lo) and math.isfinite(hi) and hi > lo}


def n_corners(model: ProcessModel, ci95: Mapping[str, tuple[float, float]]) -> int:
    """How many box corners :func:`parameter_sets` puts after the nominal set."""
    spans = _spans({**model.params, "delay": 0.0}, ci95)
    return 2 ** len(spans) if spans and len(spans) <= MAX_CORNER_PARAMS else 0


def _time_scale(structure: str, p: Mapping[str, float]) -> float:
    ts = STRUCTURES[structure].time_scale(p)
    return float(ts) if math.isfinite(ts) else 0.0


def loop_scale(model_ts: float, delay: float, controller: Controller) -> float:
    """A characteristic time of the loop for the frequency grid: the plant's time scale
    or dead time, failing both (a bare integrator) the controller's integral time."""
    ts = max(model_ts, delay)
    if ts > 0:
        return ts
    for v in (controller.Ti, controller.Td):
        if math.isfinite(v) and v > 0:
            return v
    return 1.0


def batch_loops(structure: str, sets: Sequence[Mapping[str, float]], controller: Controller
                ) -> tuple[Callable[[np.ndarray], np.ndarray], float, float]:
    """``L(s)`` of ``controller`` on every parameter set, as the batch callable
    :func:`~pipeline.tuning.margins.sensitivity_peaks` reads, with the largest dead time
    and time scale of the batch."""
    names = list(sets[0])
    arrays = {k: np.array([p[k] for p in sets], dtype=np.float64) for k in names}
    delay = float(np.max(arrays.get("delay", np.zeros(1))))
    ts = max(_time_scale(structure, p) for p in sets)

    def loops(s: np.ndarray) -> np.ndarray:
        return controller.response(s)[None, :] * batch_response(structure, arrays, s)

    return loops, delay, loop_scale(ts, delay, controller)


def worst_case(model: ProcessModel, controller: Controller,
               sets: Sequence[Mapping[str, float]], corners: int = 0) -> WorstCase:
    """The controller checked on every parameter set (the first is the nominal model,
    the next ``corners`` the box's corners, the rest covariance draws)."""
    loops, delay, ts = batch_loops(model.structure, sets, controller)
    origin = int(controller.integrating) + int(model.integrating)
    ms, stable = sensitivity_peaks(loops, delay=delay, time_scale=ts, origin_poles=origin,
                                   rhp_poles=rhp_poles(model))
    ms = np.where(stable, ms, np.inf)
    i = int(np.argmax(ms))
    bad = ~np.asarray(stable, dtype=bool)
    return WorstCase(ms=float(ms[i]), stable_fraction=float(np.mean(stable)),
                     n_sets=len(sets), params=dict(sets[i]), n_corners=int(corners),
                     unstable_corners=int(bad[1:1 + corners].sum()),
                     unstable_draws=int(bad[1 + corners:].sum()))
