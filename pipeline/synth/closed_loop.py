"""A closed-loop log with known truth: a PI controller on a first-order-plus-dead-time
plant, setpoint steps, the controller output logged as the "input".

Such a log looks like a step test to a careless reader (the input jumps at each setpoint
step) but is not one: the controller keeps moving the input while the output responds,
so a step-response method reads a wrong gain. The grader must say so
(``closed_loop_suspected``); this generator is its test bench.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..record import Record, make_record


def pi_loop_record(*, K: float = 2.0, T: float = 10.0, delay: float = 1.0,
                   Kc: float | None = None, Ti: float | None = None, dt: float = 0.1,
                   t_end: float = 300.0, r0: float = 50.0,
                   setpoints: Sequence[tuple[float, float]] = ((20.0, 60.0), (120.0, 45.0),
                                                               (220.0, 55.0)),
                   u0: float | None = None, noise: float = 0.0, seed: int = 0,
                   name: str = "pi_loop") -> Record:
    """Simulate ``u = PI(r - y)`` on ``K e^{-delay s}/(T s+1)`` sampled at ``dt``.

    The plant is the exact ZOH discretisation ``x[k+1] = a x[k] + K (1 - a) u[k - d]``
    (``a = e^{-dt/T}``, ``d = delay/dt`` samples), the controller the velocity-form PI
    ``u[k] = u[k-1] + Kc (e[k] - e[k-1]) + Kc dt/Ti e[k]`` on the measured output. The
    default tuning is SIMC (Skogestad 2003: ``Kc = T/(K (tau_c + delay))``,
    ``Ti = min(T, 4 (tau_c + delay))`` with ``tau_c = delay``). The loop starts at rest at
    the setpoint ``r0`` (``u0 = r0 / K`` unless given); white measurement noise of
    standard deviation ``noise`` enters the controller as it would on a real loop.
    """
    tau_c = delay
    Kc = Kc if Kc is not None else T / (K * (tau_c + delay))
    Ti = Ti if Ti is not None else min(T, 4.0 * (tau_c + delay))
    n = int(round(t_end / dt)) + 1
    t = np.arange(n) * dt
    r = np.full(n, float(r0))
    for t_c, level in sorted(setpoints):
        r[t >= t_c - 1e-9] = level
    d = int(round(delay / dt))
    a = math.exp(-dt / T)
    u_rest = float(u0) if u0 is not None else r0 / K
    y_rest = K * u_rest
    v = np.random.default_rng(seed).normal(0.0, noise, n) if noise > 0 else np.zeros(n)
    x = np.full(n, y_rest)  # plant output without noise
    u = np.full(n, u_rest)
    e_prev = 0.0
    for k in range(n):
        if k > 0:
            x[k] = a * x[k - 1] + K * (1.0 - a) * u[max(k - 1 - d, 0)]
        e = r[k] - (x[k] + v[k])
        if k > 0:
            u[k] = u[k - 1] + Kc * (e - e_prev) + Kc * dt / Ti * e
        e_prev = e
    return make_record(t, u, x + v, name=name, source=f"<synthetic {name}>")
