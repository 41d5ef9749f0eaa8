"""The simulation engine's two workloads against a bare ``lfilter`` floor, interleaved in one
run (issue 26: keep one exact-ZOH engine, the faster).

    python benchmarks/simulation_engines.py [--n 5000] [--reps 1000]

On an ``n``-sample step from 0, per structure:

* **floor**: ``scipy.signal.lfilter(b, a, u)`` with ``(b, a)`` made once, outside the
  timing (what any exact ZOH simulation must at least do);
* **new parameters**: a different parameter set every call (a refinement's residual
  evaluations: no cache can hit), through the refinement's path;
* **same model**: one model object again and again (validation, scoring, plots).

Before the move the two workloads went through two engines: ``pipeline.basis.
forced_response`` (the filter made on every call) and ``pipeline.simulation.simulate``
(a filter cached per model, made with a whole-sample shift and a DC-gain correction);
after it, through one: :func:`pipeline.simulation.forced_response` and
:func:`pipeline.simulation.simulate` share one filter builder
(:func:`pipeline.simulation.zoh.filter_of`), the second with a cache. The script runs at
either commit. The best of ``reps`` interleaved calls is kept (noise only adds time).
Prints a Markdown table: microseconds per call and the ratio to the floor.
"""

from __future__ import annotations

import argparse
import importlib
import os
import platform
import subprocess
import time

import numpy as np
from scipy import signal

STRUCTS = {
    "first_order": {"K": 2.0, "T": 40.0, "delay": 3.3},
    "second_order": {"K": 1.0, "zeta": 0.4, "wn": 0.08, "delay": 3.3},
    "two_lags": {"K": 1.5, "T1": 40.0, "T2": 9.0, "delay": 3.3},
    "zero_two_lags": {"K": 1.5, "Tz": -5.0, "T1": 40.0, "T2": 9.0, "delay": 3.3},
    "lead_lag": {"K": 1.5, "Tz": 20.0, "T": 40.0, "delay": 3.3},
    "integrator_lag": {"K": 0.1, "T": 30.0, "delay": 3.3},
}


def engines():
    """``(label, new-parameters call, same-model call)`` of the code at hand."""
    simulation = importlib.import_module("pipeline.simulation")
    try:  # before the move: two engines
        basis = importlib.import_module("pipeline.basis")
        return ("two engines (basis.forced_response, simulation.simulate)",
                basis.forced_response, simulation.simulate)
    except ImportError:
        return ("one engine (simulation.forced_response, simulation.simulate)",
                simulation.forced_response, simulation.simulate)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=5000)
    ap.add_argument("--reps", type=int, default=1000)
    a = ap.parse_args()
    from pipeline.models import ProcessModel

    label, forced_response, simulate = engines()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    dt = 1.0
    t = np.arange(a.n) * dt
    u = np.ones(a.n)
    print(f"{label} at {commit}; {a.n} samples, best of {a.reps}; "
          f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}\n")
    print("| structure | floor (us) | new parameters (us) | x floor | same model (us) | x floor |")
    print("|---|---:|---:|---:|---:|---:|")
    rng = np.random.default_rng(0)
    for name, p in STRUCTS.items():
        model = ProcessModel(name, dict(p))
        b, den, _ = signal.cont2discrete(model.num_den(), dt, method="zoh")
        b, den = np.ravel(b), np.ravel(den)
        best = {"floor": np.inf, "new": np.inf, "same": np.inf}
        for _ in range(a.reps):
            q = {k: v * (1 + 1e-3 * rng.standard_normal()) for k, v in p.items()}
            s = time.perf_counter()
            signal.lfilter(b, den, u)
            best["floor"] = min(best["floor"], time.perf_counter() - s)
            s = time.perf_counter()
            q["K"] * forced_response(name, q, t, u, dt)
            best["new"] = min(best["new"], time.perf_counter() - s)
            s = time.perf_counter()
            simulate(model, t, u, 0.0, 0.0, dt=dt)
            best["same"] = min(best["same"], time.perf_counter() - s)
        f = best["floor"]
        print(f"| {name} | {f * 1e6:.0f} | {best['new'] * 1e6:.0f} | {best['new'] / f:.2f} | "
              f"{best['same'] * 1e6:.0f} | {best['same'] / f:.2f} |")


if __name__ == "__main__":
    main()
