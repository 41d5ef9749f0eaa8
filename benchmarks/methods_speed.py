"""Per-event cost of the graphical methods as the event window grows (issue 14 item 5).

    python benchmarks/methods_speed.py [--baseline DIR] [--rounds 3] [--reps 5]

One plant (two lags 10 s and 3 s, dead time 1 s, 1 % noise, a step at 30 s and 130 s of
window after it), sampled finer and finer so that the event window after t0 holds 500,
5,000 and 50,000 samples. Each measurement runs every graphical method registered for a
step (:func:`pipeline.methods.identify`) on a fresh copy of the event (nothing carried
over from the previous event), median of ``--reps``, in a worker process whose
``PYTHONPATH`` is this checkout or ``--baseline`` (a directory holding another version's
``pipeline`` package, e.g. ``git archive <commit> pipeline | tar -x -C DIR``). The two
versions are run interleaved, ``--rounds`` times, and the median per version is kept;
contention from other processes hits both alike. Prints a Markdown table: milliseconds
per event, the ratio baseline / this checkout, the growth exponent ``d log(cost) /
d log(samples)`` between neighbouring sizes, and the largest relative difference of any
fitted parameter between the two versions (the results must not change).

    python benchmarks/methods_speed.py --crossover

prints the crossover of :func:`pipeline.signal.savgol` (overlap-add FFT) against
``scipy.signal.savgol_filter`` (direct convolution) by window length, interleaved, and
their largest difference (the reason for ``SAVGOL_FFT_TAPS``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

SIZES = (500, 5_000, 50_000)
WINDOW = 130.0  # seconds of window after the step
T_STEP = 30.0


def event(n: int):
    """The plant's step event with ``n`` samples after t0."""
    from pipeline.events import EventData
    from pipeline.models import ProcessModel
    from pipeline.segmentation.detect import segment
    from pipeline.synth import step_record

    truth = ProcessModel("two_lags", {"K": 1.5, "T1": 10.0, "T2": 3.0, "delay": 1.0})
    rec = step_record(truth, u0=2.0, changes=[(T_STEP, 5.0)], t_end=T_STEP + WINDOW,
                      dt=WINDOW / n, y0=7.0, noise=0.045, seed=0)
    return EventData.from_event(rec, segment(rec)[0])


def worker(n: int, reps: int) -> dict:
    """Median seconds per event of all graphical step methods, and their parameters."""
    from pipeline.methods import REGISTRY, identify

    ev = event(n)
    ids = [m.id for m in REGISTRY.values() if m.kind == "graphical" and m.accepts("step")]
    fits = [identify(replace(ev), m) for m in ids]  # warm-up (chart tables, imports)
    times = []
    for _ in range(reps):
        fresh = replace(ev)  # a new event object: no reading of the last one is reused
        t0 = time.perf_counter()
        fits = [identify(fresh, m) for m in ids]
        times.append(time.perf_counter() - t0)
    times.sort()
    return {"seconds": times[len(times) // 2], "samples": int(ev.t.size - ev.i0),
            "params": {f.method: (f.model.params if f.model else f.reason) for f in fits}}


def run_worker(tree: Path, n: int, reps: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, __file__, "--worker", str(n), "--reps", str(reps)],
                         env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def largest_difference(a: dict, b: dict) -> float:
    """Largest relative difference of a parameter between two runs (inf: a status moved)."""
    worst = 0.0
    for mid, pa in a.items():
        pb = b.get(mid)
        if isinstance(pa, str) or isinstance(pb, str):
            if pa != pb and (isinstance(pa, str) != isinstance(pb, str)):
                return math.inf
            continue
        for k, va in pa.items():
            vb = pb[k]
            worst = max(worst, abs(va - vb) / max(abs(va), abs(vb), 1e-300))
    return worst


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--baseline", type=Path, help="a directory holding another pipeline")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    ap.add_argument("--crossover", action="store_true")
    ap.add_argument("--worker", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker, args.reps)))
        return
    if args.crossover:
        crossover(args.reps)
        return
    here = Path(__file__).resolve().parent.parent
    trees = {"this": here} | ({"baseline": args.baseline.resolve()} if args.baseline else {})
    runs: dict[tuple[str, int], list[dict]] = {}
    for _ in range(args.rounds):
        for n in args.sizes:
            for name, tree in trees.items():
                runs.setdefault((name, n), []).append(run_worker(tree, n, args.reps))
    med = {key: sorted(r["seconds"] for r in rs)[len(rs) // 2] for key, rs in runs.items()}
    base = f" --baseline {args.baseline}" if args.baseline else ""
    if args.sizes != list(SIZES):
        base += " --sizes " + " ".join(map(str, args.sizes))
    print(f"`python benchmarks/methods_speed.py{base}"
          f" --rounds {args.rounds} --reps {args.reps}` on CPython {platform.python_version()}, "
          f"{os.cpu_count()} CPU(s), {platform.machine()}\n")
    head = "| samples after t0 | this checkout (ms/event) | growth exponent |"
    rule = "|---:|---:|---:|"
    if args.baseline:
        head += (" baseline (ms/event) | growth exponent | baseline / this |"
                 " largest parameter difference |")
        rule += "---:|---:|---:|---:|"
    print(head)
    print(rule)
    prev = None
    for n in args.sizes:
        samples = runs[("this", n)][0]["samples"]
        row = f"| {samples:,} | {1e3 * med[('this', n)]:.1f} | "
        row += _exponent(prev, samples, med, "this", n) + " |"
        if args.baseline:
            diff = largest_difference(runs[("baseline", n)][0]["params"],
                                      runs[("this", n)][0]["params"])
            row += (f" {1e3 * med[('baseline', n)]:.1f} | "
                    f"{_exponent(prev, samples, med, 'baseline', n)} | "
                    f"{med[('baseline', n)] / med[('this', n)]:.2f}x | {diff:.1e} |")
        print(row)
        prev = (samples, n)


def crossover(reps: int) -> None:
    """Direct against overlap-add Savitzky-Golay smoothing, by window length."""
    import numpy as np
    from scipy.signal import oaconvolve, savgol_coeffs, savgol_filter

    def oa(h, w):  # the interior of pipeline.signal.savgol, whatever its threshold
        return oaconvolve(h, savgol_coeffs(w, 2, use="conv"), mode="same")

    print(f"`python benchmarks/methods_speed.py --crossover --reps {reps}`\n")
    print("| samples | taps | savgol_filter (ms) | overlap-add (ms) | ratio | max difference |")
    print("|---:|---:|---:|---:|---:|---:|")
    rng = np.random.default_rng(0)
    for n in (5_000, 60_000, 500_000):
        h = 1.0 - np.exp(-np.arange(n) / (n / 5)) + 0.01 * rng.normal(size=n)
        for w in (51, 101, 201, 401, 1201, 10001):
            if w > n // 25:
                continue
            times: dict[str, list[float]] = {"direct": [], "oa": []}
            outs = {}
            for _ in range(reps):
                for name, f in (("direct", lambda h=h, w=w: savgol_filter(h, w, 2)),
                                ("oa", lambda h=h, w=w: oa(h, w))):
                    t0 = time.perf_counter()
                    outs[name] = f()
                    times[name].append(time.perf_counter() - t0)
            d = float(np.max(np.abs((outs["direct"] - outs["oa"])[w:-w])))
            a, b = (sorted(v)[len(v) // 2] for v in times.values())
            print(f"| {n:,} | {w} | {1e3 * a:.2f} | {1e3 * b:.2f} | {a / b:.2f}x | {d:.1e} |")


def _exponent(prev, samples: int, med: dict, name: str, n: int) -> str:
    if prev is None:
        return ""
    s0, n0 = prev
    return f"{math.log(med[(name, n)] / med[(name, n0)]) / math.log(samples / s0):.2f}"


if __name__ == "__main__":
    main()
