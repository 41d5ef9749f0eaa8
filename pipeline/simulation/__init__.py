"""Simulation: the exact zero-order-hold engine for uniform and irregular grids, and the
forced, free and offset responses the least-squares fits are built from.
"""

from .engine import simulate
from .regressors import each_free_column, forced_response, offset_response, uniform_step
from .zoh import memory

__all__ = ["each_free_column", "forced_response", "memory", "offset_response", "simulate",
           "uniform_step"]
