"""Per-event refinements, this tree against another one, interleaved (issue 14 item 5).

    python benchmarks/refine_events.py --baseline DIR [--rounds 5] [--reps 3]

``DIR`` holds another ``pipeline`` package (e.g. ``git archive REV pipeline | tar -x -C
DIR``). The record is the scale benchmark's staircase (:func:`scale.write_log`'s plant:
K 2, T one eighth of a window, delay 3 samples, white noise), 60,000 samples with 12
windows of about 5,000 samples; each ``lsq_<structure>`` of the settling structures runs
on events 1 to 5 from the graphical starts the analysis gives it (``first_order`` and
``viteckova1``'s models), state at rest. Each round runs both trees, each in a fresh
process (one BLAS thread), and keeps the best of ``--reps`` per structure; the table gives
the median over rounds, ms per refinement, and the ratio this / baseline. Every
refinement's parameters are compared between the two trees (the largest relative
difference is printed).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
STRUCTURES = ("first_order", "second_order", "two_lags", "n_lags", "zero_two_lags",
              "lead_lag")


def worker(reps: int) -> None:
    import numpy as np
    from scipy.signal import lfilter

    from pipeline.events import EventData
    from pipeline.methods import identify
    from pipeline.record import make_record
    from pipeline.segmentation.detect import segment

    n, n_events, dt = 60_000, 11, 0.1
    rng = np.random.default_rng(0)
    w = n // (n_events + 1)
    levels = 5.0 + (-1.0) ** np.arange(n_events) * rng.uniform(0.6, 1.4, n_events)
    u = np.full(n, 5.0)
    for k in range(n_events):
        u[(k + 1) * w:] = levels[k]
    a = math.exp(-dt / (w * dt / 8))
    delayed = np.concatenate([np.full(3, 5.0), u[:-3]])
    y = 20.0 + lfilter([0.0, 2.0 * (1 - a)], [1.0, -a], delayed - 5.0, zi=[0.0])[0] \
        + rng.normal(0.0, 0.02, n)
    rec = make_record(np.arange(n) * dt, u, y, name="r", source="<r>")
    evs = [EventData.from_event(rec, e) for e in segment(rec)[1:6]]
    starts = [[f.model for f in (identify(ev, "first_order"), identify(ev, "viteckova1"))
               if f.ok] for ev in evs]
    best, params = {}, {}
    for _ in range(reps):
        for s in STRUCTURES:
            c = time.process_time()
            fits = [identify(ev, f"lsq_{s}", models=m, state="rest")
                    for ev, m in zip(evs, starts, strict=True)]
            best[s] = min(best.get(s, math.inf), (time.process_time() - c) / len(evs))
            params[s] = [dict(f.model.params) if f.ok else None for f in fits]
    print(json.dumps({"ms": {s: 1e3 * v for s, v in best.items()}, "params": params}))


def run(tree: Path, reps: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1",
           "OMP_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, __file__, "--worker", str(reps)], env=env,
                         check=True, capture_output=True, text=True, cwd=tree).stdout
    return json.loads(out)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--baseline", type=Path, help="a directory holding another pipeline")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--worker", type=int, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        return worker(a.worker)
    if a.baseline is None:
        ap.error("--baseline DIR is needed")
    this, base = [], []
    for _ in range(a.rounds):
        this.append(run(ROOT, a.reps))
        base.append(run(a.baseline.resolve(), a.reps))
    worst = 0.0
    for s in STRUCTURES:
        for p, q in zip(this[0]["params"][s], base[0]["params"][s], strict=True):
            if p and q:
                worst = max(worst, *(abs(p[k] - q[k]) / max(abs(q[k]), 1e-300) for k in p))
    print(f"CPython {sys.version.split()[0]}, {os.cpu_count()} CPU(s), load "
          f"{os.getloadavg()[0]:.1f}; {a.rounds} rounds, best of {a.reps}\n")
    print("| structure | this (ms) | baseline (ms) | this / baseline |")
    print("|---|---:|---:|---:|")
    tot_t = tot_b = 0.0
    for s in STRUCTURES:
        t = statistics.median(r["ms"][s] for r in this)
        b = statistics.median(r["ms"][s] for r in base)
        tot_t, tot_b = tot_t + t, tot_b + b
        print(f"| {s} | {t:.1f} | {b:.1f} | {t / b:.2f} |")
    print(f"| all six | {tot_t:.1f} | {tot_b:.1f} | {tot_t / tot_b:.2f} |")
    print(f"\nlargest relative parameter difference: {worst:.1e}")


if __name__ == "__main__":
    main()
