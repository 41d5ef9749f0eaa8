"""The variance factor's cost on long residuals, this tree against another (issue 30 item 5).

    python benchmarks/variance_factor_speed.py --baseline DIR [--rounds 3]

``DIR`` holds another ``pipeline`` package (``git archive REV pipeline | tar -x -C DIR``).
For residuals of 10,000, 20,000 and 50,000 samples of AR(1) noise (phi 0.97, fixed seed),
each tree runs :func:`pipeline.uncertainty.variance_factor` 20 times in a fresh process
(one BLAS thread); the median over rounds of the CPU per call, the ratio this / baseline,
and both factors (they agree to rounding).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SIZES = (10_000, 20_000, 50_000)


def worker() -> None:
    import time

    import numpy as np
    from scipy.signal import lfilter

    from pipeline.uncertainty import variance_factor

    out = {}
    for n in SIZES:
        e = lfilter([1.0], [1.0, -0.97], np.random.default_rng(n).normal(size=n))
        t = time.process_time()
        for _ in range(20):
            f = variance_factor(e)
        out[str(n)] = (1e3 * (time.process_time() - t) / 20, f)
    print(json.dumps(out))


def run(tree: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1"}
    return json.loads(subprocess.run([sys.executable, __file__, "--worker"], env=env,
                                     check=True, capture_output=True, text=True).stdout)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--baseline", type=Path)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        return worker()
    if a.baseline is None:
        ap.error("--baseline DIR is needed")
    this, base = [], []
    for _ in range(a.rounds):
        this.append(run(ROOT))
        base.append(run(a.baseline.resolve()))
    print(f"CPython {sys.version.split()[0]}, {os.cpu_count()} CPU(s), load "
          f"{os.getloadavg()[0]:.1f}; {a.rounds} rounds\n")
    print("| residual samples | this (ms) | baseline (ms) | this / baseline | factor this | "
          "factor baseline |")
    print("|---:|---:|---:|---:|---:|---:|")
    for n in map(str, SIZES):
        t = statistics.median(r[n][0] for r in this)
        b = statistics.median(r[n][0] for r in base)
        print(f"| {int(n):,} | {t:.2f} | {b:.2f} | {t / b:.3f} | {this[0][n][1]:.12g} | "
              f"{base[0][n][1]:.12g} |")


if __name__ == "__main__":
    main()
