"""The floor of ``pipeline identify FILE --method all --events all`` (issue 14): how much of
its CPU is the filtering of the model simulations alone.

    python benchmarks/identify_floor.py LOG.csv [--input u --output y --time time]
                                        [--reps 3]

Every least-squares search, interval, cross-validation fold and held-out score of the
command simulates its model, and on a uniform grid a model of order 2 or less (every
structure but the long and non-integer equal-lag chains) by ``scipy.signal.lfilter``
(:mod:`pipeline.simulation.regressors`: the exact ZOH recursion). That filtering is part of the
arithmetic of the searches the command runs: any implementation of the same searches,
with no Python overhead at all, does at least it, and the number of simulations is set
by the searches (their starts, iterations, finite-difference Jacobians), so it cannot
fall without changing which optimum is found. The equal-lag chains' convolutions and
irregular grids' propagation are not timed: the floor printed is a lower bound.

This script runs the command in this process with each ``lfilter`` call timed
(``time.perf_counter`` around it, the wrapper's own cost outside the timed interval),
and, before and after, ``python benchmarks/scale.py --worker bare LOG`` in a fresh
process (``polars.read_csv`` and the three columns as numpy arrays, the issue's bare
read) ``--reps`` times. It prints the command's CPU, the filters' time by simulated span
length, and both as multiples of the bare read's process CPU (its median).

The logs: ``python benchmarks/scale.py --sizes 1000000:200 --keep DIR`` writes
``DIR/scale_1000000_200.csv``.
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import io
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: Simulated span lengths the filter time is split by (upper bounds, samples).
BUCKETS = (1_000, 10_000, 100_000)


def bare_process_cpu(log: Path) -> float:
    """CPU (user + system) of a fresh process that reads ``log`` with polars."""
    scale = ROOT / "benchmarks" / "scale.py"
    before = os.times()
    subprocess.run([sys.executable, str(scale), "--worker", "bare", str(log)], check=True,
                   stdout=subprocess.DEVNULL, env={**os.environ, "PYTHONPATH": str(ROOT)})
    after = os.times()
    return (after.children_user - before.children_user) + \
        (after.children_system - before.children_system)


def bucket(n: int) -> str:
    for b in BUCKETS:
        if n <= b:
            return f"<= {b:,}"
    return f"> {BUCKETS[-1]:,}"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("log", type=Path)
    ap.add_argument("--input", default="u")
    ap.add_argument("--output", default="y")
    ap.add_argument("--time", default="time")
    ap.add_argument("--reps", type=int, default=3)
    a = ap.parse_args()
    bare = [bare_process_cpu(a.log) for _ in range(a.reps)]

    import numpy as np
    from scipy import signal

    from pipeline.cli.commands import app

    filters: dict[str, list[float]] = collections.defaultdict(lambda: [0, 0.0])
    lfilter = signal.lfilter

    def timed(num, den, x, axis=-1, zi=None):
        t = time.perf_counter()
        out = lfilter(num, den, x, axis=axis, zi=zi)
        dt = time.perf_counter() - t
        f = filters[bucket(int(np.size(x)))]
        f[0] += 1
        f[1] += dt
        return out

    signal.lfilter = timed  # pipeline.simulation.regressors calls it as signal.lfilter: this one
    cpu = time.process_time()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
        app(["identify", str(a.log), "--input", a.input, "--output", a.output, "--time",
             a.time, "--method", "all", "--events", "all", "--json"], standalone_mode=False)
    cpu = time.process_time() - cpu
    signal.lfilter = lfilter
    bare += [bare_process_cpu(a.log) for _ in range(a.reps)]
    b = statistics.median(bare)
    total = sum(f[1] for f in filters.values())
    calls = sum(f[0] for f in filters.values())
    out = sys.stdout
    print(f"\nbare read's process: median {b:.2f} s CPU ({min(bare):.2f}-{max(bare):.2f}, "
          f"{len(bare)} runs)", file=out)
    print(f"identify --method all --events all: {cpu:.1f} s CPU = {cpu / b:.0f}x the bare "
          f"read", file=out)
    print(f"its simulations' filtering alone: {total:.1f} s in {calls:,} lfilter calls = "
          f"{total / b:.0f}x the bare read ({total / cpu:.0%} of the command)", file=out)
    for k in sorted(filters, key=lambda k: (k.startswith(">"), len(k), k)):
        n, s = filters[k]
        print(f"  spans {k:>12s} samples: {n:8,d} calls {s:7.2f} s", file=out)


if __name__ == "__main__":
    main()
