"""The two exact-ZOH engines of the move (issue 26), interleaved in one run: which to keep.

    python benchmarks/simulation_engines.py [--n 5000] [--reps 2000]

Both build the exact zero-order-hold filter of a rational model of order <= 2 in closed
form and apply it with ``scipy.signal.lfilter``; they differ in how the filter is made:

* **simulation** (``pipeline.simulation.zoh.zoh_filter`` then ``pipeline.simulation.simulate``):
  a whole-sample dead time as a shift, the numerator's DC gain corrected to the model's,
  the filter cached per model and sample time;
* **basis** (``pipeline.simulation.forced_response``, what validation and every refinement
  residual used): the filter made on every call, no shift, no DC correction.

Two workloads per structure, on an ``n``-sample step from 0: *new parameters* every call
(a refinement's residual evaluations: no cache can hit) and *the same model* every call
(validation, plots). The best of ``reps`` interleaved calls is kept (noise only adds
time). Prints a Markdown table: microseconds per call, and the ratio basis / simulation.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

STRUCTS = {
    "first_order": {"K": 2.0, "T": 40.0, "delay": 3.3},
    "second_order": {"K": 1.0, "zeta": 0.4, "wn": 0.08, "delay": 3.3},
    "two_lags": {"K": 1.5, "T1": 40.0, "T2": 9.0, "delay": 3.3},
    "zero_two_lags": {"K": 1.5, "Tz": -5.0, "T1": 40.0, "T2": 9.0, "delay": 3.3},
    "lead_lag": {"K": 1.5, "Tz": 20.0, "T": 40.0, "delay": 3.3},
    "integrator_lag": {"K": 0.1, "T": 30.0, "delay": 3.3},
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=5000)
    ap.add_argument("--reps", type=int, default=2000)
    a = ap.parse_args()
    try:  # the engines of main before the move; after it, the one engine twice
        from pipeline.simulation.engine import simulate
        from pipeline.simulation.regressors import forced_response
        engines = "simulation vs basis"
    except ImportError:
        from pipeline.simulation.engine import forced_response, simulate
        engines = "one engine (simulate vs forced_response)"
    from pipeline.models import ProcessModel

    dt = 1.0
    t = np.arange(a.n) * dt
    u = np.ones(a.n)
    print(f"{engines}; {a.n} samples, best of {a.reps}; {platform.processor() or 'cpu'}, "
          f"{os.cpu_count()} cores, Python {platform.python_version()}\n")
    print("| structure | workload | simulation (us) | basis (us) | basis / simulation |")
    print("|---|---|---:|---:|---:|")
    rng = np.random.default_rng(0)
    for name, p in STRUCTS.items():
        for workload in ("new parameters", "same model"):
            best = {"simulation": np.inf, "basis": np.inf}
            for _ in range(a.reps):
                q = dict(p) if workload == "same model" else {
                    k: v * (1 + 1e-3 * rng.standard_normal()) for k, v in p.items()}
                m = ProcessModel(name, q) if workload != "same model" else \
                    _same.setdefault(name, ProcessModel(name, q))
                s = time.perf_counter()
                simulate(m, t, u, 0.0, 0.0, dt=dt)
                best["simulation"] = min(best["simulation"], time.perf_counter() - s)
                s = time.perf_counter()
                m.K * forced_response(name, q, t, u, dt)
                best["basis"] = min(best["basis"], time.perf_counter() - s)
            print(f"| {name} | {workload} | {best['simulation'] * 1e6:.0f} | "
                  f"{best['basis'] * 1e6:.0f} | {best['basis'] / best['simulation']:.2f} |")


_same: dict = {}

if __name__ == "__main__":
    main()
