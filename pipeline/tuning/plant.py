"""A process model's frequency response with its exact dead time, one parameter set or a
batch of them (the worst case over an interval evaluates hundreds at once).

``P(s) = G(s) e^(-delay s)`` with ``G`` the structure's rational part from the structure
table (:data:`pipeline.models.STRUCTURES`, ``num_den``), evaluated by Horner's scheme so
that each coefficient may be an array of parameter sets; ``n_lags`` is evaluated as
``K (T s + 1)^(-n)`` (principal branch, analytic in the right half plane), which holds for
a non-integer ``n`` too.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..models import STRUCTURES, ProcessModel


def _horner(coeffs, s: np.ndarray) -> np.ndarray:
    out = np.zeros(np.broadcast_shapes(*(np.shape(c) for c in coeffs), s.shape),
                   dtype=np.complex128)
    for c in coeffs:
        out = out * s + c
    return out


def batch_response(structure: str, params: Mapping[str, np.ndarray], s: np.ndarray
                   ) -> np.ndarray:
    """``P(s)`` for ``m`` parameter sets at once: ``params`` maps each parameter to an
    array of shape ``(m,)`` (or a scalar), ``s`` is 1-D; the result has shape ``(m, len(s))``
    (``(len(s),)`` when every parameter is a scalar)."""
    s = np.asarray(s, dtype=np.complex128)
    scalar = all(np.ndim(v) == 0 for v in params.values())
    p = {k: (float(v) if scalar else np.asarray(v, dtype=np.float64)[:, None])
         for k, v in params.items()}
    delay = p.get("delay", 0.0)
    if structure == "n_lags":
        g = p["K"] * (p["T"] * s + 1.0) ** (-p["n"])
    else:
        nd = STRUCTURES[structure].num_den(p)
        if nd is None:  # pragma: no cover - only n_lags lacks a rational form
            raise ValueError(f"{structure} has no rational form")
        num, den = nd
        g = _horner(num, s) / _horner(den, s)
    return g * np.exp(-delay * s)


def response(model: ProcessModel, s: np.ndarray) -> np.ndarray:
    """``P(s)`` of one model at the complex points ``s`` (1-D)."""
    params = {k: float(v) for k, v in model.params.items()}
    params.setdefault("delay", 0.0)
    return batch_response(model.structure, params, s)


def rhp_poles(model: ProcessModel) -> int:
    """Poles of the rational part with a positive real part (none inside the structures'
    bounds; counted so that the Nyquist test never assumes it)."""
    nd = model.num_den()
    if nd is None:
        return 0  # equal real lags: T > 0 by the bounds
    roots = np.roots(np.asarray(nd[1], dtype=np.float64))
    return int(np.sum(roots.real > 1e-12 * max(1.0, float(np.max(np.abs(roots)))
                                               if roots.size else 1.0)))
