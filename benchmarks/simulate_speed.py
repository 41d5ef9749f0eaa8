"""Simulation speed: pipeline.simulate (exact ZOH + lfilter / FFT pulse response) against
python-control's forced_response on the same model and input, in the same run.

    python benchmarks/simulate_speed.py [--n 200000] [--reps 5]

Prints a Markdown table (median wall time of --reps runs, the ratio, and the largest
difference between the two outputs, which must be at rounding level).
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import control
import numpy as np

from pipeline.models import ProcessModel
from pipeline.simulation import simulate

MODELS = {
    "K/(Ts+1)": ProcessModel("first_order", {"K": 2.0, "T": 7.0}),
    "second order, zeta 0.31": ProcessModel("second_order", {"K": 0.25, "zeta": 0.31,
                                                             "wn": 5.05}),
    "(0.5s+1)^5 (FFT pulse response)": ProcessModel("n_lags", {"K": 2.0, "T": 0.5, "n": 5}),
}


def median_time(f, reps: int) -> tuple[float, np.ndarray]:
    times, out = [], None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=200_000)
    ap.add_argument("--reps", type=int, default=5)
    args = ap.parse_args()
    dt = 0.01
    t = np.arange(args.n) * dt
    u = np.repeat(np.random.default_rng(0).normal(size=args.n // 100 + 1), 100)[: args.n]
    print(f"`python benchmarks/simulate_speed.py --n {args.n} --reps {args.reps}` on "
          f"CPython {platform.python_version()}, {os.cpu_count()} CPU(s), "
          f"python-control {control.__version__}\n")
    print("| model | pipeline (s) | forced_response (s) | ratio | max abs difference |")
    print("|---|---:|---:|---:|---:|")
    for name, m in MODELS.items():
        ours, y = median_time(lambda m=m: simulate(m, t, u, 0.0, 0.0), args.reps)
        sysd = control.c2d(m.transfer_function(), dt, "zoh")
        ref, r = median_time(lambda s=sysd: control.forced_response(s, t, u).outputs,
                             max(1, args.reps // 2))
        print(f"| {name} | {ours:.4f} | {ref:.2f} | {ref / ours:.0f}x | "
              f"{np.max(np.abs(np.asarray(r) - y)):.1e} |")


if __name__ == "__main__":
    main()
