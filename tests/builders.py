"""Event builders for the method tests: one set, on top of :mod:`pipeline.synth`.

Every builder simulates a plant exactly (zero-order hold, ``pipeline.synth``) from a
nonzero operating point, adds noise of a known marginal standard deviation (white, or
AR(1) with coefficient ``phi``: coloured noise), and segments the arrays like any log
(:func:`pipeline.segmentation.detect.event_data`), so ``Event.noise`` is what the pipeline itself
estimates. Noise levels are relative: steps to the output change ``K du``, impulses to the
peak output deviation.

``plant(...)`` spells the test plants in the parameter vocabulary of DESIGN.md.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.signal import lfilter

from pipeline.events import EventData
from pipeline.models import ProcessModel
from pipeline.segmentation.detect import event_data
from pipeline.synth import JAKOUBEK_LAGS, lag_chain_step, pulse, response, staircase


def fo(T: float, delay: float = 0.0, K: float = 2.0) -> ProcessModel:
    return ProcessModel("first_order", {"K": K, "T": T, "delay": delay})


def nl(T: float, n: float, delay: float = 0.0, K: float = 2.0) -> ProcessModel:
    return ProcessModel("n_lags", {"K": K, "T": T, "n": n, "delay": delay})


def tl(T1: float, T2: float, delay: float = 0.0, K: float = 2.0) -> ProcessModel:
    return ProcessModel("two_lags", {"K": K, "T1": T1, "T2": T2, "delay": delay})


def so(zeta: float, wn: float, delay: float = 0.0, K: float = 2.0) -> ProcessModel:
    return ProcessModel("second_order", {"K": K, "zeta": zeta, "wn": wn, "delay": delay})


def noise(n: int, sigma: float, phi: float = 0.0, seed: int | None = 0) -> np.ndarray:
    """Stationary noise of marginal standard deviation ``sigma``: white (``phi = 0``) or
    AR(1) ``e_k = phi e_{k-1} + w_k`` with ``var w = sigma^2 (1 - phi^2)``, started in its
    stationary distribution."""
    rng = np.random.default_rng(seed)
    if sigma == 0:
        return np.zeros(n)
    if phi == 0:
        return rng.normal(0.0, sigma, n)
    w = rng.normal(0.0, sigma * math.sqrt(1.0 - phi * phi), n)
    return lfilter([1.0], [1.0, -phi], w, zi=[phi * rng.normal(0.0, sigma)])[0]


def step_arrays(model: ProcessModel, *, u0: float = 1.0, u1: float = 2.0, t0: float = 3.0,
                y0: float = 5.0, dt: float = 0.01, after: float = 20.0, noise_rel: float = 0.0,
                phi: float = 0.0, seed: int | None = 0
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t, u, y)`` of a step ``u0 -> u1`` at ``t0``, ``after`` seconds recorded after it."""
    t = np.arange(int(round((t0 + after) / dt)) + 1) * dt
    u = staircase(t, u0, [(t0, u1)])
    y = response(model, t, u, u0, y0)
    sd = noise_rel * abs(model.K * (u1 - u0))
    return t, u, y + noise(t.size, sd, phi, seed)


def step(model: ProcessModel, *, seed: int | None = 0, **kw) -> EventData:
    """The segmented step event of :func:`step_arrays` (same keywords)."""
    t, u, y = step_arrays(model, seed=seed, **kw)
    return event_data(t, u, y, initial_input=kw.get("u0", 1.0))


def impulse(model: ProcessModel, *, u0: float = 0.0, t_on: float = 1.0, width: float = 0.2,
            height: float = 3.0, y0: float = 0.0, dt: float = 0.01, t_end: float = 41.0,
            noise_rel: float = 0.0, phi: float = 0.0, seed: int | None = 0) -> EventData:
    """A rectangular pulse of ``height`` for ``width`` s (area = height x width) from the
    baseline ``u0``; ``noise_rel`` relative to the peak output deviation."""
    t = np.arange(int(round(t_end / dt)) + 1) * dt
    u = pulse(t, u0, t_on, width, height)
    y = response(model, t, u, u0, y0)
    sd = noise_rel * float(np.max(np.abs(y - y0)))
    return event_data(t, u, y + noise(t.size, sd, phi, seed), initial_input=u0)


def lag_chain(lags: tuple[float, ...], *, dt: float = 1e-3, t0: float = 3.0,
              after: float = 25.0, u0: float = 1.0, u1: float = 2.0, y0: float = 5.0,
              K: float = 2.0, noise_rel: float = 0.0, phi: float = 0.0,
              seed: int | None = 0) -> EventData:
    """A step into ``K / prod(T_i s + 1)`` (any lags, e.g. Jakoubek's eq. 30), exact on
    the grid (:func:`pipeline.synth.lag_chain_step`)."""
    t = np.arange(int(round((t0 + after) / dt)) + 1) * dt
    u = np.where(t >= t0 - 1e-9, u1, u0)
    y = y0 + (u1 - u0) * lag_chain_step(lags, t - t0, K=K)
    y = y + noise(t.size, noise_rel * abs(K * (u1 - u0)), phi, seed)
    return event_data(t, u, y, initial_input=u0)


def jakoubek(system: int, dt: float = 1e-3) -> EventData:
    """Jakoubek's system 1-5 (seed 002 eqs 26-30): gain 2, step u 1 -> 2 at t0 = 3 s from
    y0 = 5, 25 s recorded, noise-free."""
    return lag_chain(JAKOUBEK_LAGS[system], dt=dt)


def flat(kind: str = "step", *, noise_sd: float = 0.0, seed: int = 0) -> EventData:
    """An input step or pulse with an output that does not respond (only noise)."""
    t = np.arange(1301) * 0.01
    u = pulse(t, 1.0, 3.0, 0.5, 1.0) if kind == "impulse" else staircase(t, 1.0, [(3.0, 2.0)])
    y = 5.0 + noise(t.size, noise_sd, 0.0, seed)
    return event_data(t, u, y, initial_input=1.0)


def truncated(ev: EventData, n: int) -> EventData:
    """The first ``n`` samples of an event (a window cut short)."""
    return replace(ev, t=ev.t[:n], u=ev.u[:n], y=ev.y[:n])
