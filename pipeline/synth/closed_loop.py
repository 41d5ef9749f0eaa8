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
from .montecarlo import ar1_noise


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


#: Plants of the closed-loop bench (:func:`loop_record`): continuous transfer functions
#: ``num/den`` (coefficients, highest power first) and a dead time, with a controller
#: tuned for each by SIMC (Skogestad 2003, Table 1; the integrating rule for the
#: unstable lags, which the paper's sec. 5 treats as integrating when tau1 >> theta).
LOOP_PLANTS: dict[str, tuple[tuple[float, ...], tuple[float, ...], float]] = {
    "fopdt": ((2.0,), (10.0, 1.0), 1.0),
    "two_lags": ((1.0,), (24.0, 11.0, 1.0), 1.0),            # 1/((8s+1)(3s+1))
    "integrator_lag": ((0.2,), (3.0, 1.0, 0.0), 2.0),         # 0.2/(s(3s+1))
    "unstable": ((1.0,), (10.0, -1.0), 0.5),                  # 1/(10s-1)
    "unstable_lag": ((1.0,), (20.0, 8.0, -1.0), 0.2),         # 1/((10s-1)(2s+1))
}

#: SIMC settings (ideal form: Kc, Ti, Td) per plant of :data:`LOOP_PLANTS` with
#: ``tau_c = theta`` (PI; PID with Td the second lag where there is one; the ideal form of
#: the series settings, ``Kc (1 + Td/Ti)``, ``Ti + Td``, ``Ti Td / (Ti + Td)``).
def _series(kc: float, ti: float, td: float) -> tuple[float, float, float]:
    return kc * (1 + td / ti), ti + td, ti * td / (ti + td)


LOOP_TUNINGS: dict[str, dict[str, tuple[float, float, float]]] = {
    "fopdt": {"P": (2.5, math.inf, 0.0), "PI": (2.5, 8.0, 0.0)},
    "two_lags": {"PI": (4.0, 8.0, 0.0), "PID": _series(4.0, 8.0, 3.0)},
    "integrator_lag": {"P": (1.25, math.inf, 0.0), "PI": (1.25, 16.0, 0.0),
                       "PID": _series(1.25, 16.0, 3.0)},
    "unstable": {"P": (10.0, math.inf, 0.0), "PI": (10.0, 4.0, 0.0)},
    "unstable_lag": {"PID": _series(12.5, 1.6, 2.0)},  # half SIMC's Kc of 25: less kick
}


def loop_record(plant: str, controller: str, *, detune: float = 1.0, dt: float = 0.1,
                t_end: float = 300.0, r0: float = 50.0,
                setpoints: Sequence[tuple[float, float]] = ((20.0, 55.0), (120.0, 47.0),
                                                            (220.0, 52.0)),
                loads: Sequence[tuple[float, float]] = (), noise: float = 0.0,
                noise_phi: float = 0.0, seed: int = 0, name: str | None = None,
                gain: float = 1.0) -> Record:
    """A closed loop of one of :data:`LOOP_PLANTS` under its :data:`LOOP_TUNINGS`
    ``controller`` (``P``, ``PI`` or ``PID``; Kc divided by ``detune``), the controller
    output logged as the input; ``gain`` multiplies the plant's (a plant that drifted
    under settings tuned for the bench's).

    The plant is the ZOH discretisation of its transfer function (``scipy.signal.
    cont2discrete``) behind a dead time of whole samples, started at rest; the load
    ``(time, size)`` steps add to the controller output at the plant's input. The
    controller is the positional ideal PID ``u = u_b + Kc (e + I + D)``, ``I`` the
    forward-Euler integral of ``e / Ti``, ``D`` the derivative of the measured output
    (not of the error: no derivative kick) filtered by ``Td / 10``, on the measured output
    ``y + v``; ``v`` is measurement noise of standard deviation ``noise``, white or AR(1)
    with ``noise_phi``. The bias ``u_b`` holds the loop at rest at ``r0``.
    """
    from scipy.signal import cont2discrete, tf2ss

    num, den, delay = LOOP_PLANTS[plant]
    num = tuple(gain * x for x in num)  # a plant whose gain drifted (the tuning does not)
    kc, ti, td = LOOP_TUNINGS[plant][controller]
    kc /= detune
    a, b, c, dd, _ = cont2discrete(tf2ss(num, den), dt, "zoh")
    a, b, c = np.asarray(a), np.asarray(b).ravel(), np.asarray(c).ravel()
    d0 = float(np.asarray(dd).ravel()[0])
    n_state = a.shape[0]
    n = int(round(t_end / dt)) + 1
    t = np.arange(n) * dt
    r = np.full(n, float(r0))
    for t_c, level in sorted(setpoints):
        r[t >= t_c - 1e-9] = level
    load = np.zeros(n)
    for t_c, size in sorted(loads):
        load[t >= t_c - 1e-9] += size
    integrating = den[-1] == 0.0
    static = 0.0 if integrating else num[-1] / den[-1]
    u_rest = 0.0 if integrating else r0 / static
    # the state at rest: x = A x + B u, y = C x + D u = r0 (an integrator: the state whose
    # output is r0 with u = 0)
    if integrating:
        x = np.linalg.lstsq(np.vstack([a - np.eye(n_state), c]), np.r_[np.zeros(n_state),
                            r0], rcond=None)[0]
    else:
        x = np.linalg.solve(np.eye(n_state) - a, b * u_rest)
    rng = np.random.default_rng(seed)
    v = np.zeros(n) if noise <= 0 else rng.normal(0.0, noise, n) if noise_phi == 0 \
        else ar1_noise(n, noise, noise_phi, rng)
    lag = int(round(delay / dt))
    u = np.full(n, u_rest)
    y = np.empty(n)
    tf = td / 10.0
    integral, deriv, y_prev = 0.0, 0.0, None
    for k in range(n):
        u_plant = (u[k - 1 - lag] if k - 1 - lag >= 0 else u_rest) + (load[k - 1] if k else 0)
        if k:
            x = a @ x + b * u_plant
        y[k] = float(c @ x) + d0 * u_plant
        m = y[k] + v[k]
        e = r[k] - m
        if td > 0 and y_prev is not None:
            deriv = tf / (tf + dt) * deriv - td / (tf + dt) * (m - y_prev)
        y_prev = m
        u[k] = u_rest + kc * (e + integral + deriv)
        if math.isfinite(ti):
            integral += dt / ti * e
    label = name or f"{plant} {controller}"
    return make_record(t, u, y + v, name=label, source=f"<synthetic {label}>")
