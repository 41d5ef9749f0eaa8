"""The plant identified through its closed loop, the controller known (issue 32 item 1, the
indirect approach): the model of the plant inside the loop, fitted to the loop's response
from the setpoint ``r`` to the measurement ``y``.

The direct approach (fitting ``u -> y`` as in open loop) is biased where the measurement
noise feeds back through the controller into ``u``: the input is then correlated with the
noise. The setpoint is not: with the controller known, the closed loop ``r -> y`` is a
function of the plant's parameters alone, so an output-error fit of it is consistent and
its intervals are the ordinary ones (L. Ljung, System Identification, 2nd ed., 1999,
sec. 13.4 "indirect identification"; P. M. J. Van den Hof, "Closed-loop issues in system
identification", Annual Reviews in Control 22:173-186, 1998).

Both halves are exact discrete systems:

* the plant: the structure's exact ZOH filter with its fractional dead time,
  ``G = z^-lag b(z^-1) / a(z^-1)`` (:func:`pipeline.simulation.filter_of`);
* the controller as :mod:`pipeline.tuning.running` reads it off the log: the positional
  ideal PID, forward-Euler integral, the derivative on the measurement through the
  backward-Euler filter ``Tf``: ``u = Ce (r - y) - Cd y`` with
  ``Ce = Kc (1 + (h/Ti) z^-1 / (1 - z^-1))`` and
  ``Cd = Kc (Td / (Tf + h)) (1 - z^-1) / (1 - Tf/(Tf + h) z^-1)``;

so ``y = G Ce / (1 + G (Ce + Cd)) r``, one rational filter, simulated by ``lfilter`` on
the setpoint's change from its first sample (the loop at rest there) plus an offset
solved linearly. The plant's gain enters the loop nonlinearly, so it is searched with
the dynamics (``scipy.optimize.least_squares``, trust-region reflective, log scale
where positive), from a start (the direct fit's model). Intervals: the Jacobian's
covariance with the residuals' variance factor (:func:`pipeline.uncertainty.covariance`),
on log scale for positive parameters.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter

from ..fit import ParameterCovariance
from ..models import STRUCTURES, ProcessModel
from ..simulation import filter_of
from ..uncertainty import covariance, t_quantile, variance_factor
from .refinement import INTEGER_PARAMS, MIN_DOF, canonical, intervals
from .search import FTOL, search_space


class Controller(Protocol):
    """The settings this module reads (:class:`pipeline.tuning.Controller` has them; the
    refinement does not import the tuning, which imports it): ideal form, seconds, ``Ti``
    inf without integral action, ``Tf`` the derivative filter's time constant."""

    Kc: float
    Ti: float
    Td: float
    Tf: float


@dataclass(frozen=True)
class ClosedLoopFit:
    """The plant fitted through its loop: the ``model``, its 95 % intervals and standard
    errors, the offset, the residuals' RMS and variance factor, and the residual
    evaluations the search took."""

    model: ProcessModel
    ci95: dict[str, tuple[float, float]]
    std: dict[str, float]
    offset: float
    rms: float
    variance_factor: float
    nfev: int


def controller_polynomials(c: Controller, h: float
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(Nc, Dc, Nd, Dd)`` in powers of ``z^-1``: the error path ``Ce = Nc/Dc`` and the
    measurement's derivative path ``Cd = Nd/Dd`` of the controller sampled at ``h``
    (module docstring)."""
    if math.isfinite(c.Ti):
        nc, dc = c.Kc * np.array([1.0, h / c.Ti - 1.0]), np.array([1.0, -1.0])
    else:
        nc, dc = np.array([c.Kc]), np.array([1.0])
    if c.Td > 0:
        nd = c.Kc * c.Td / (c.Tf + h) * np.array([1.0, -1.0])
        dd = np.array([1.0, -c.Tf / (c.Tf + h)])
    else:
        nd, dd = np.array([0.0]), np.array([1.0])
    return nc, dc, nd, dd


def _add(*polys: np.ndarray) -> np.ndarray:
    out = np.zeros(max(p.size for p in polys))
    for p in polys:
        out[: p.size] += p
    return out


def loop_filter(structure: str, params: Mapping[str, float], c: Controller, h: float
                ) -> tuple[np.ndarray, np.ndarray] | None:
    """``(num, den)`` in powers of ``z^-1`` of the closed loop ``r -> y`` (module
    docstring); None where the structure has no exact ZOH filter."""
    f = filter_of(structure, params, h)
    if f is None:
        return None
    k = float(params["K"])
    bz = np.r_[np.zeros(f.lag), k * np.asarray(f.b, np.float64)]
    a = np.asarray(f.a, np.float64)
    nc, dc, nd, dd = controller_polynomials(c, h)
    num = np.convolve(np.convolve(bz, nc), dd)
    den = _add(np.convolve(np.convolve(a, dc), dd), num,
               np.convolve(np.convolve(bz, nd), dc))
    return num, den


def loop_response(structure: str, params: Mapping[str, float], c: Controller, h: float,
                  r: np.ndarray) -> np.ndarray | None:
    """The measurement's change the closed loop makes from the setpoint ``r`` (its change
    from ``r[0]``, the loop at rest there); None where the loop cannot be simulated."""
    nd = loop_filter(structure, params, c, h)
    if nd is None or not nd[1][0]:
        return None
    return lfilter(nd[0], nd[1], np.asarray(r, np.float64) - float(r[0]))


def fit_through_loop(t, r, y, controller: Controller, structure: str,
                     start: Mapping[str, float], *, max_nfev: int = 200,
                     level: float = 0.95) -> ClosedLoopFit:
    """The plant ``structure`` fitted to the closed loop's ``r -> y`` on the uniform grid
    ``t``, the ``controller`` known, from the parameters ``start`` (module docstring). The
    gain's sign is the controller's (a loop that regulates feeds back negatively: ``Kc``
    carries the process gain's sign); an order (:data:`pipeline.refine.refinement.
    INTEGER_PARAMS`) is held at the start's, rounded. Raises ValueError, with the reason,
    where it cannot be fitted: an irregular grid, a setpoint that never changes, a
    structure without an exact filter or with direct feedthrough (a sampled controller
    cannot react within its own sample), a search that does not converge or a loop the
    data do not determine."""
    t, r, y = (np.asarray(a, np.float64) for a in (t, r, y))
    h = float(np.median(np.diff(t)))
    if not h > 0 or np.max(np.abs(np.diff(t) - h)) > 0.01 * h:
        raise ValueError("the loop's log must be sampled uniformly (within 1 %)")
    if not np.ptp(r) > 0:
        raise ValueError("the setpoint never changes: nothing drives the loop to fit the "
                         "plant from (a regulation log: its loads are not measured)")
    spec = STRUCTURES[structure]
    fixed = {n: float(max(round(float(start[n])), 1)) for n in spec.params
             if n in INTEGER_PARAMS}
    k_sign = math.copysign(1.0, controller.Kc if controller.Kc else float(start["K"]))
    first = {**start, **fixed, "K": k_sign * max(abs(float(start["K"])), 1e-12)}
    f0 = filter_of(structure, first, h)
    if f0 is None:
        raise ValueError(f"a {structure.replace('_', ' ')} model has no exact discrete "
                         "filter of order 1 or 2 to close the loop with")
    if f0.lag == 0:
        raise ValueError(f"the {structure.replace('_', ' ')} model responds within its own "
                         "sample (direct feedthrough): a sampled loop cannot be closed on it")
    names = [n for n in spec.params if n != "K" and n not in fixed]
    span = float(t[-1] - t[0])
    space = search_space(structure, names, h, span)

    def params_of(z: np.ndarray) -> dict[str, float]:
        return {"K": k_sign * math.exp(z[0]), **space.from_z(z[1:]), **fixed}

    def residual(z: np.ndarray) -> np.ndarray:
        sim = loop_response(structure, params_of(z), controller, h, r)
        if sim is None or not np.all(np.isfinite(sim)) or np.max(np.abs(sim)) > 1e100:
            return np.full(y.size, 1e150)
        e = y - sim
        return e - float(np.mean(e))  # the offset, solved linearly

    z0 = np.r_[math.log(abs(first["K"])), space.to_z(first)]
    lo, hi = np.r_[-50.0, space.lo], np.r_[50.0, space.hi]
    try:
        res = least_squares(residual, z0, bounds=(lo, hi), method="trf", ftol=FTOL,
                            xtol=FTOL, max_nfev=max_nfev)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise ValueError(f"the fit through the loop failed ({exc})") from None
    e = residual(res.x)
    rms = float(np.sqrt(np.mean(e * e)))
    if res.status <= 0 or not rms < 1e100:
        raise ValueError("the fit through the loop did not converge (the loop is unstable "
                         "with the start's plant, or the search stopped after "
                         f"{res.nfev} evaluations)")
    p = params_of(res.x)
    sim = loop_response(structure, p, controller, h, r)
    offset = float(np.mean(y - sim))
    factor = variance_factor(e)
    cov = covariance(res.jac, e, res.x.size + 1, factor)
    se_z = np.sqrt(np.maximum(np.diag(cov), 0.0))
    if not np.all(np.isfinite(se_z)) or not np.all(se_z > 0):
        raise ValueError("the loop's response does not determine the plant's parameters "
                         "(the setpoint's steps do not excite it)")
    q = t_quantile(max(e.size / factor - res.x.size - 1, MIN_DOF), level)
    # the gain was searched as log|K|: its coordinate as the refinement's intervals take
    # it, K itself, by the delta method (dK = K dlog|K|), after the searched parameters
    k = p["K"]
    d = np.r_[k, np.ones(len(space.names))]
    order = [*range(1, res.x.size), 0]
    cov_k = (cov * np.outer(d, d))[np.ix_(order, order)]
    cov_z = ParameterCovariance(
        (*space.names, "K"), (*map(bool, space.log), False), (*map(float, space.scale), 1.0),
        (*map(float, res.x[1:]), k), tuple(tuple(map(float, row)) for row in cov_k))
    ci, std = intervals(structure, cov_z, p, q)
    p, ci, std = canonical(structure, p, ci, std)
    return ClosedLoopFit(ProcessModel(structure, p), ci, std, offset, rms, factor,
                         int(res.nfev))
