"""Synthetic plant logs with known truth, for tests, examples and benchmarks.

The output is the exact response of a :class:`~pipeline.models.ProcessModel` to a
piecewise-constant (zero-order hold) input, from a steady operating point, plus white
noise. Nothing here reads or writes files.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .models import ProcessModel
from .record import Record, make_record
from .simulate import simulate


def staircase(t: np.ndarray, u0: float, changes: Sequence[tuple[float, float]]) -> np.ndarray:
    """Input that starts at ``u0`` and jumps to ``level`` at each ``(time, level)``."""
    u = np.full(t.size, float(u0))
    for t_c, level in sorted(changes):
        u[t >= t_c - 1e-9 * max(1.0, abs(t_c))] = level
    return u


def pulse(t: np.ndarray, u0: float, t_on: float, width: float, height: float) -> np.ndarray:
    """Input at ``u0`` with a rectangular pulse of ``height`` above it on [t_on, t_on+width)."""
    u = np.full(t.size, float(u0))
    eps = 1e-9 * max(1.0, abs(t_on))
    u[(t >= t_on - eps) & (t < t_on + width - eps)] += height
    return u


def response(model: ProcessModel, t, u, u0: float, y0: float, noise: float = 0.0,
             seed: int | None = 0) -> np.ndarray:
    """Exact output plus white noise of standard deviation ``noise``."""
    y = simulate(model, t, u, u0, y0)
    if noise > 0:
        y = y + np.random.default_rng(seed).normal(0.0, noise, size=y.size)
    return y


def step_record(model: ProcessModel, *, u0: float, changes: Sequence[tuple[float, float]],
                t_end: float, dt: float, y0: float, noise: float = 0.0, seed: int | None = 0,
                name: str = "synthetic", input_noise: float = 0.0) -> Record:
    """A record of ``model`` driven by a staircase input (see :func:`staircase`)."""
    t = np.arange(int(round(t_end / dt)) + 1) * dt
    u = staircase(t, u0, changes)
    y = response(model, t, u, u0, y0, noise, seed)
    if input_noise > 0:
        u = u + np.random.default_rng(None if seed is None else seed + 1).normal(
            0.0, input_noise, size=u.size)
    return make_record(t, u, y, name=name, source=f"<synthetic {name}>")
