"""Simulation speed: ``pipeline.simulate`` against a bare ``scipy.signal.lfilter`` of the same
model on the same input, interleaved in one run.

    python benchmarks/simulate_speed.py [--sizes 1000 5000 100000 1000000] [--reps 15]

For each model and record length, the repetitions of the variants alternate (so a busy
machine slows them alike) and the best of each is kept (``timeit``'s convention: on the
shared machine a call on a 100 k-sample array took 1.5 ms or 10 ms at random, page faults
of its fresh output under the other jobs' memory pressure, so medians flipped between the
modes; noise only adds time):

* **lfilter** (the floor): ``lfilter(b, a, u - u0)`` with ``(b, a)`` of the rational part
  from ``cont2discrete`` computed once, outside the timing (the dead time, a shift, is not
  in the floor: as leading zeros of ``b`` it would make lfilter's order 30);
* **simulate(dt)**: ``simulate(model, t, u, u0, y0, dt=dt)``, the sample time from the
  record, as the pipeline calls it;
* **simulate**: the public call on arrays alone (the sample time inferred from ``t``);
* **previous**: the implementation before the closed forms (a ``cont2discrete`` and a
  sample-time check per call), for reference.

Prints a Markdown table of the ratios to the floor and the largest difference between
``simulate`` and the floor (rounding level).
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np
from scipy import signal

from pipeline.models import ProcessModel
from pipeline.record import uniform_step
from pipeline.simulation.engine import simulate

DT = 0.01
MODELS = {
    "first order, delay 0.3 s": ProcessModel("first_order", {"K": 2.0, "T": 7.0,
                                                               "delay": 0.3}),
    "second order zeta 0.31, delay 0.3 s": ProcessModel(
        "second_order", {"K": 0.25, "zeta": 0.31, "wn": 5.05, "delay": 0.3}),
    "two lags, delay 0.3 s": ProcessModel("two_lags", {"K": 1.5, "T1": 10.0, "T2": 3.0,
                                                         "delay": 0.3}),
}


def previous(model: ProcessModel, t, u, u0, y0):
    """The simulator before the closed forms, for models of order <= 2 and a whole-sample
    dead time (cont2discrete and a sample-time check on every call)."""
    t = np.asarray(t, dtype=np.float64)
    dt = uniform_step(t, 1e-4)
    du = np.asarray(u, dtype=np.float64) - u0
    n, whole = du.size, round(model.delay / dt)
    b, a, _ = signal.cont2discrete(model.num_den(), dt, method="zoh")
    y = signal.lfilter(np.ravel(b), np.ravel(a), du)
    if whole:
        y = np.concatenate([np.zeros(min(whole, n)), y[: max(n - whole, 0)]])
    return y0 + y


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 5000, 100_000, 1_000_000])
    ap.add_argument("--reps", type=int, default=15)
    args = ap.parse_args()
    print(f"`python benchmarks/simulate_speed.py --sizes {' '.join(map(str, args.sizes))} "
          f"--reps {args.reps}` on CPython {platform.python_version()}, "
          f"{os.cpu_count()} CPU(s), load {os.getloadavg()[0]:.1f}\n")
    print("| model | samples | lfilter (floor) | simulate(dt) | simulate | previous "
          "| max abs diff |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    rng = np.random.default_rng(0)
    for name, m in MODELS.items():
        b, a, _ = signal.cont2discrete(m.num_den(), DT, method="zoh")
        b, a, lag = np.ravel(b), np.ravel(a), round(m.delay / DT)
        for n in args.sizes:
            t = np.arange(n) * DT
            u = 3.0 + np.repeat(rng.normal(size=n // 100 + 1), 100)[:n]
            variants = {
                "floor": lambda u=u, b=b, a=a: signal.lfilter(b, a, u - 3.0),
                "dt": lambda t=t, u=u, m=m: simulate(m, t, u, 3.0, 0.0, dt=DT),
                "public": lambda t=t, u=u, m=m: simulate(m, t, u, 3.0, 0.0),
                "previous": lambda t=t, u=u, m=m: previous(m, t, u, 3.0, 0.0),
            }
            times = {k: [] for k in variants}
            reps = args.reps if n < 500_000 else max(3, args.reps // 3)
            for _ in range(reps):
                for k, f in variants.items():
                    t0 = time.perf_counter()
                    f()
                    times[k].append(time.perf_counter() - t0)
            med = {k: float(np.min(v)) for k, v in times.items()}
            ref = np.concatenate([np.zeros(lag), variants["floor"]()[: n - lag]])
            diff = float(np.max(np.abs(variants["dt"]() - ref)))
            print(f"| {name} | {n:,} | {med['floor'] * 1e3:.3f} ms | "
                  f"{med['dt'] / med['floor']:.2f}x | {med['public'] / med['floor']:.2f}x | "
                  f"{med['previous'] / med['floor']:.2f}x | {diff:.1e} |")


if __name__ == "__main__":
    main()
