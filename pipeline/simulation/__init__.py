"""Simulation: one exact zero-order-hold engine for uniform and irregular grids, and the
columns the least-squares fits are built from.

- :mod:`.engine` - :func:`simulate` (a model from its operating point) and
  :func:`forced_response` (the unit-gain response under every simulation and fit);
- :mod:`.zoh` - the closed-form ZOH filters, the model's memory, the state space and
  transitions of irregular grids;
- :mod:`.regressors` - the free and offset responses beside the forced one.
"""

from .engine import UNIFORM_REL_TOL, forced_response, simulate
from .regressors import each_free_column, free_basis, offset_response
from .zoh import filter_of, memory

__all__ = ["UNIFORM_REL_TOL", "each_free_column", "filter_of", "forced_response",
           "free_basis", "memory", "offset_response", "simulate"]
