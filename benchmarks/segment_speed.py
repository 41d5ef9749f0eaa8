"""Segmentation speed (issue 14 item 2): cost against samples and events, growth exponents.

    python benchmarks/segment_speed.py [--reps 1] [--no-old] [--big 10000000]

Synthetic records (``bench_record``): a first-order plant under a random staircase from a
nonzero level, noisy input and output, 10 ms sampling; at 1 M samples with 20 / 200 / 2000
events and at 100 k / 1 M / ``--big`` samples with 200 events. Each ``segment`` run is
interleaved with its baseline, the bare pass over the same arrays (``np.diff`` of u and y
and ``np.abs`` of them: what any reading of the record costs), and the ratio is reported;
the growth exponents are least-squares slopes of log time on log size. The time spent in
:func:`pipeline.signal.smooth` is reported apart: its Savitzky-Golay width is 2 % of the
window, so its direct convolution is quadratic in the window (the methods' smoothing,
issue 14 item 5, replaces it by an overlap-add FFT). ``--no-old`` skips the reference: the
implementation before issue 14 (read from git at ``BASE``), on the 1 M-sample records
only (it is quadratic in samples: 10 M would take it minutes).

One BLAS thread (threadpoolctl) for everything measured: on 2 shared cores OpenBLAS's
threaded dot products cost 75 ms each instead of 20 us (pipeline.batch does the same).
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import time
import types
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

import pipeline.segmentation.detect as seg
from pipeline.models import ProcessModel
from pipeline.record import make_record
from pipeline.simulation.engine import simulate

#: The commit before issue 14's segmentation (the reference implementation).
BASE = "6ff9e78"
ROOT = Path(__file__).resolve().parents[1]


def bench_record(n: int, events: int, seed: int = 0, dt: float = 0.01):
    """``events`` steps evenly spaced over ``n`` samples, levels at least 0.3 apart in
    [0, 3]; lag T = 1/8 of the hold; input noise 0.002, output noise 0.01."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    hold = n // (events + 1)
    u = np.zeros(n)
    level = 0.0
    for e in range(events):
        new = level
        while abs(new - level) < 0.3:
            new = float(rng.uniform(0, 3))
        u[(e + 1) * hold :] = new
        level = new
    model = ProcessModel("first_order", {"K": 2.0, "T": max(hold * dt / 8, 5 * dt)})
    y = simulate(model, t, u, 0.0, 0.0) + rng.normal(0, 0.01, n)
    return make_record(t, u + rng.normal(0, 0.002, n), y, name="bench", source="<bench>")


def old_segment():
    """The segmentation module at BASE, imported from git."""
    src = subprocess.run(["git", "show", f"{BASE}:pipeline/segmentation.py"], cwd=ROOT,
                         check=True, capture_output=True, text=True).stdout
    mod = types.ModuleType("pipeline._segmentation_base")
    mod.__package__ = "pipeline"
    sys.modules[mod.__name__] = mod  # its dataclasses look their module up
    exec(compile(src, f"{BASE}:pipeline/segmentation.py", "exec"), mod.__dict__)
    return mod.segment


def bare(rec) -> None:
    np.abs(np.diff(rec.u))
    np.abs(np.diff(rec.y))


class SmoothClock:
    """Wraps segmentation's ``smooth`` and adds up the time spent in it."""

    def __init__(self) -> None:
        self.spent, self.inner = 0.0, seg.smooth

    def __call__(self, *a, **k):
        t0 = time.process_time()
        try:
            return self.inner(*a, **k)
        finally:
            self.spent += time.process_time() - t0


def clock(f) -> float:
    t0 = time.process_time()
    f()
    return time.process_time() - t0


def fit_exponent(x, y) -> float:
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument("--no-old", action="store_true")
    ap.add_argument("--big", type=int, default=10_000_000)
    args = ap.parse_args()
    sizes = [(1_000_000, 20), (1_000_000, 200), (1_000_000, 2000), (100_000, 200),
             (args.big, 200)]
    old = None if args.no_old else old_segment()
    sm = SmoothClock()
    seg.smooth = sm
    print(f"`python benchmarks/segment_speed.py --reps {args.reps}"
          f"{' --no-old' if args.no_old else ''} --big {args.big}` on CPython "
          f"{platform.python_version()}, {os.cpu_count()} CPU(s), load average "
          f"{os.getloadavg()[0]:.1f}; CPU seconds (process time), median of {args.reps}\n")
    print("| samples | events | segment (s) | of which smooth (s) | bare pass (s) | "
          "segment / bare | before issue 14 (s) | speed-up |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    rows = {}
    with threadpool_limits(limits=1):
        for n, e in sizes:
            rec = bench_record(n, e)
            runs, smooths, bases, olds = [], [], [], []
            for _ in range(args.reps):  # interleaved: baseline, new, (old), baseline
                bases.append(clock(lambda r=rec: bare(r)))
                sm.spent = 0.0
                runs.append(clock(lambda r=rec: seg.segment(r)))
                smooths.append(sm.spent)
                if old is not None and n == 1_000_000:
                    olds.append(clock(lambda r=rec: old(r)))
                bases.append(clock(lambda r=rec: bare(r)))
            got = len(seg.segment(rec))
            assert got == e, f"{got} events found, {e} made"
            if olds:
                assert old(rec) == seg.segment(rec), "not the same events as before"
            r, s, b = (float(np.median(v)) for v in (runs, smooths, bases))
            o = float(np.median(olds)) if olds else None
            rows[(n, e)] = (r, s, b)
            print(f"| {n:,} | {e} | {r:.2f} | {s:.2f} | {b:.3f} | {r / b:.0f} | "
                  f"{'-' if o is None else f'{o:.2f}'} | "
                  f"{'-' if o is None else f'{o / r:.1f}x'} |", flush=True)
    ns = [100_000, 1_000_000, args.big]
    es = [20, 200, 2000]
    for label, pick in (("segment", lambda v: v[0]), ("segment less smooth",
                                                      lambda v: v[0] - v[1])):
        a = fit_exponent(ns, [pick(rows[(n, 200)]) for n in ns])
        b = fit_exponent(es, [pick(rows[(1_000_000, e)]) for e in es])
        print(f"\n{label}: growth exponent {a:.2f} in samples (200 events), "
              f"{b:.2f} in events (1 M samples)", end="")
    print()


if __name__ == "__main__":
    sys.exit(main())
