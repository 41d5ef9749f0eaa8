"""Synthetic plants with known truth: exact responses to staircase and pulse inputs.

The output is the exact response of a :class:`~pipeline.models.ProcessModel` to a
piecewise-constant (zero-order hold) input, from a steady operating point, plus white
noise. Nothing here reads or writes files.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..models import ProcessModel
from ..record import Record, make_record
from ..simulation import simulate


def staircase(t: np.ndarray, u0: float, changes: Sequence[tuple[float, float]]) -> np.ndarray:
    """Input that starts at ``u0`` and jumps to ``level`` at each ``(time, level)``."""
    u = np.full(t.size, float(u0))
    for t_c, level in sorted(changes):
        u[t >= t_c - 1e-9 * max(1.0, abs(t_c))] = level
    return u


def ramped_staircase(t: np.ndarray, u0: float, changes: Sequence[tuple[float, float]],
                     ramp: float) -> np.ndarray:
    """:func:`staircase` whose each change is a ramp of ``ramp`` (time units) from the
    level before it (an actuator with a rate limit, a valve that opens over seconds, a
    boiler switched in: real steps are rarely ideal); ``ramp`` 0 is the staircase. The
    changes are at least ``ramp`` apart (each ramp starts from the level before it)."""
    if ramp <= 0:
        return staircase(t, u0, changes)
    u, before = np.full(t.size, float(u0)), float(u0)
    for t_c, level in sorted(changes):
        share = np.clip((t - t_c) / ramp, 0.0, 1.0)
        u = np.where(t >= t_c, before + (level - before) * share, u)
        before = level
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


#: Jakoubek's five test systems (seed 002 eqs. 26-30), gain 2, as chains of real lags.
JAKOUBEK_LAGS: dict[int, tuple[float, ...]] = {
    1: (0.5,),
    2: (0.5, 0.5),
    3: (1.0, 0.1),
    4: (0.5,) * 5,
    5: (0.2, 0.4, 0.6, 0.8, 1.0),
}


def lag_chain_step(lags: Sequence[float], t, K: float = 1.0) -> np.ndarray:
    """Unit step response of K / prod(T_i s + 1) (distinct lags: partial fractions
    ``1 - sum_i c_i e^{-t/T_i}``, ``c_i = T_i^(n-1) / prod_{j != i}(T_i - T_j)``; equal lags:
    the incomplete gamma function)."""
    from scipy.special import gammainc

    t = np.asarray(t, dtype=np.float64)
    out = np.zeros_like(t)
    pos = t > 0
    if len(set(lags)) == 1:
        out[pos] = gammainc(len(lags), t[pos] / lags[0])
        return K * out
    s = np.ones(int(pos.sum()))
    for i, ti in enumerate(lags):
        c = ti ** (len(lags) - 1) / np.prod([ti - tj for j, tj in enumerate(lags) if j != i])
        s -= c * np.exp(-t[pos] / ti)
    out[pos] = s
    return K * out


def jakoubek_record(system: int, *, dt: float = 1e-3, t0: float = 3.0, after: float = 25.0,
                    u0: float = 1.0, u1: float = 2.0, y0: float = 5.0) -> Record:
    """Jakoubek's system ``system`` (1-5) stepped from a nonzero operating point, noise-free
    and exact on the grid (the input steps on a sample)."""
    t = np.arange(int(round((t0 + after) / dt)) + 1) * dt
    u = np.where(t >= t0 - 1e-9, u1, u0)
    y = y0 + (u1 - u0) * lag_chain_step(JAKOUBEK_LAGS[system], t - t0, K=2.0)
    return make_record(t, u, y, name=f"jakoubek{system}", source=f"<seed 002 system {system}>")
