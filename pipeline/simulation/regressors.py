"""The columns of the least-squares refinement beside the forced response: the free
response from an unknown initial state, and the response to an input offset. A thin
layer on the engine and the delayed step (:func:`pipeline.models.delayed_step`).

All are *unit-gain* responses of one structure of :data:`pipeline.models.STRUCTURES`
with the dead time, in deviation variables, so the model output is linear in the gain,
the output offset and the initial state (the separable form that :mod:`pipeline.refine`
exploits):

    y_hat(t) = y0 + K x(t) + sum_j c_j b_j(t) [+ c_u s(t)]

* ``x`` - the response from rest to the held input ``u - u_ref``:
  :func:`pipeline.simulation.forced_response`, the engine itself;
* :func:`free_basis` ``b_j`` - the free response from an unknown state: the response after
  the window start to unknown input pulses on ``[-tau_j, 0)`` before it,
  ``b_j(t') = S(t' + tau_j) - S(t')``, with ``tau_j`` spread over the model's time scale.
  For a settling structure these decay to zero, for an integrator they tend to constants,
  so they span the free response of every structure, dead time included (the input still
  "in the pipe") - the idea of MATLAB's ``InitialCondition = 'estimate'`` (procest)
  written for any step response. Collinear columns (a first-order lag has a
  one-dimensional free response) are left to the rank-revealing linear solve.
* :func:`offset_response` ``s`` - the response to a constant unit input from the window
  start: for an integrating structure it is the drift of an unknown input balance point
  ``u0``, so ``c_u = -K (u0 - u_ref)`` estimates ``u0`` jointly.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping

import numpy as np

from ..models import STRUCTURES, Structure, delayed_step
from .zoh import rational_order


def basis_lags(spec: Structure, p: Mapping[str, float], n_max: int = 3) -> int:
    """How many free-response columns: the number of poles of a rational model (at most
    ``n_max``), else ``n_max``."""
    order = rational_order(spec, {**p, "K": 1.0})
    if order is None:
        return n_max
    return int(min(max(order, 1), n_max))


def free_basis(structure: str, p: Mapping[str, float], t_rel: np.ndarray, horizon: float,
               n_max: int = 3) -> np.ndarray:
    """Columns ``S(t' + tau_j) - S(t')`` (``t' = t_rel >= 0``, time since the window start)
    for ``tau_j`` geometrically spread from a quarter to four times the model's time scale
    (the dead time added; ``horizon`` when the time scale is not finite or zero)."""
    return np.column_stack(list(each_free_column(structure, p, t_rel, horizon, n_max)))


def each_free_column(structure: str, p: Mapping[str, float], t_rel: np.ndarray,
                     horizon: float, n_max: int = 3) -> Iterator[np.ndarray]:
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
    s_now = delayed_step(spec, q, t_rel)
    for tau in taus:
        yield delayed_step(spec, q, t_rel + tau) - s_now


def offset_response(structure: str, p: Mapping[str, float], t_rel: np.ndarray) -> np.ndarray:
    """Response to a constant unit input from the window start (the unknown input balance
    point of an integrating structure)."""
    return delayed_step(STRUCTURES[structure], {**p, "K": 1.0}, t_rel)
