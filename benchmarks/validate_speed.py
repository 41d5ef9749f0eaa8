"""Validation cost: held-out scoring, leave-one-event-out and per-event consistency on long
logs with many events, against one bare ``lfilter`` pass over the record per model, in
the same run.

    python benchmarks/validate_speed.py [--sizes 100000:20 300000:60 1000000:200]
                                        [--previous /path/to/old/checkout]

The log: a first-order-plus-dead-time plant (K 2, T 5 s, delay 0.5 s, dt 0.01 s, 1 %
noise) driven by a staircase with one step per event window (samples / events samples
each). Identification on every other event, validation on the rest (the case of issue 14:
89.8 s CPU at 1 M samples / 200 events). Models: three structures (first order, two lags,
second order) near the truth for each identification event. Stages, CPU time:

* **score**: :func:`pipeline.validate.score` of every model (its event, then all the
  validation events, simulated continuously with the warm-up correction);
* **leave-one-out**: one model per structure scored on each identification event alone
  (:func:`pipeline.validate.heldout_residuals` with one event, what
  :func:`pipeline.refine.joint.cross_validate` does per fold);
* **consistency**: :func:`pipeline.grading.consistency.step_gains` once per structure (each
  step's own gain at shared dynamics).

The floor of each stage: one ``scipy.signal.lfilter`` pass over the whole record per model
(or per structure). With ``--previous DIR`` every size also runs with the package from
``DIR`` (e.g. a checkout of the base commit), interleaved with the current one, each in
its own subprocess. Prints a Markdown table and the growth exponent of each stage's cost
per model between the sizes (1 = linear in samples, with the events growing alike).
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

import numpy as np


def make_record(n: int, n_events: int):
    from pipeline.models import ProcessModel
    from pipeline.synth import step_record

    dt = 0.01
    per = n // n_events
    rng = np.random.default_rng(0)
    levels = 2 + rng.uniform(-1, 1, n_events)
    changes = [((i + 0.5) * per * dt, float(levels[i])) for i in range(n_events)]
    truth = ProcessModel("first_order", {"K": 2.0, "T": 5.0, "delay": 0.5})
    return step_record(truth, u0=2.0, changes=changes, t_end=(n - 1) * dt, dt=dt, y0=1.0,
                       noise=0.02, seed=1)


def run_one(n: int, n_events: int, skip_consistency: bool) -> dict:
    """One size with the package on sys.path: CPU seconds of each stage and its floor."""
    from scipy import signal

    from pipeline.grading import consistency
    from pipeline.models import ProcessModel
    from pipeline.segmentation.detect import SegmentOptions, segment
    from pipeline.validate import heldout_residuals, score

    rec = make_record(n, n_events)
    events = segment(rec, SegmentOptions())
    ident = list(range(0, len(events), 2))
    validation = [i for i in range(len(events)) if i not in ident]
    structures = [
        ProcessModel("first_order", {"K": 2.01, "T": 5.05, "delay": 0.5}),
        ProcessModel("two_lags", {"K": 2.0, "T1": 4.6, "T2": 0.5, "delay": 0.4}),
        ProcessModel("second_order", {"K": 2.0, "zeta": 1.3, "wn": 0.32, "delay": 0.45}),
    ]
    models = [(i, ProcessModel(m.structure, {**m.params, "K": m.K * (1 + 1e-4 * i)}))
              for i in ident for m in structures]
    b, a = [0.0, 0.002], [1.0, -0.998]

    def floor(count: int) -> float:
        t0 = time.process_time()
        for _ in range(count):
            signal.lfilter(b, a, rec.u - 2.0)
        return time.process_time() - t0

    out = {"n": n, "events": len(events), "models": len(models)}
    t0 = time.process_time()
    mses = [score(m, rec, events, events[i], validation)["mse_validation"] for i, m in models]
    out["score"] = time.process_time() - t0
    out["score_floor"] = floor(len(models))
    t0 = time.process_time()
    loo = [float(np.mean(heldout_residuals(m, rec, events, [j])[1] ** 2))
           for m in structures for j in ident]
    out["loo"] = time.process_time() - t0
    out["loo_floor"] = floor(len(structures))
    if not skip_consistency:
        t0 = time.process_time()
        gains = [consistency.step_gains(rec, events, m) for m in structures]
        out["consistency"] = time.process_time() - t0
        out["consistency_floor"] = floor(len(structures))
        out["gains"] = [[v[0] for v in g.values()] for g in gains]
    out["mse"] = mses
    out["loo_mse"] = loo
    return out


def spawn(root: str, n: int, e: int, skip: bool) -> dict:
    env = {**os.environ, "PYTHONPATH": root, "OPENBLAS_NUM_THREADS": "1",
           "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    cmd = [sys.executable, __file__, "--one", f"{n}:{e}"] + (["--skip-consistency"] if skip
                                                              else [])
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", nargs="+", default=["100000:20", "300000:60", "1000000:200"])
    ap.add_argument("--previous", default=None, help="checkout of the code to compare with")
    ap.add_argument("--dense-limit", type=int, default=300_000,
                    help="largest size at which the previous (dense) consistency runs")
    ap.add_argument("--one", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--skip-consistency", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        n, e = map(int, args.one.split(":"))
        print(json.dumps(run_one(n, e, args.skip_consistency)))
        return
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    roots = {"current": here} | ({"previous": args.previous} if args.previous else {})
    sizes = [tuple(map(int, s.split(":"))) for s in args.sizes]
    results: dict[str, list[dict]] = {k: [] for k in roots}
    for n, e in sizes:  # interleaved: each size runs every variant before the next size
        for name, root in roots.items():
            results[name].append(spawn(root, n, e, name == "previous" and n > args.dense_limit))
    print(f"`python benchmarks/validate_speed.py --sizes {' '.join(args.sizes)}"
          f"{' --previous ' + args.previous if args.previous else ''}` on CPython "
          f"{platform.python_version()}, {os.cpu_count()} CPU(s), load "
          f"{os.getloadavg()[0]:.1f}; CPU seconds, BLAS single-threaded\n")
    print("| code | samples / events | models | score | x floor | leave-one-out | x floor "
          "| consistency | x floor |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for name, rows in results.items():
        for r in rows:
            cons = (f"{r['consistency']:.2f} s | {r['consistency'] / r['consistency_floor']:.1f}x"
                    if "consistency" in r else "(not run) | ")
            print(f"| {name} | {r['n']:,} / {r['events']} | {r['models']} | {r['score']:.2f} s | "
                  f"{r['score'] / r['score_floor']:.1f}x | {r['loo']:.2f} s | "
                  f"{r['loo'] / r['loo_floor']:.1f}x | {cons} |")
    print("\nGrowth exponent of the cost per model (per structure for leave-one-out and "
          "consistency) between consecutive sizes (samples and events grow together):\n")
    for name, rows in results.items():
        for r0, r1 in zip(rows[:-1], rows[1:], strict=True):
            g = math.log(r1["n"] / r0["n"])

            def slope(key, per="", r0=r0, r1=r1, g=g):
                c0 = r0[key] / (r0[per] if per else 1)
                c1 = r1[key] / (r1[per] if per else 1)
                return f"{key} {math.log(c1 / c0) / g:.2f}"
            parts = [slope("score", "models"), slope("loo")]
            if "consistency" in r0 and "consistency" in r1:
                parts.append(slope("consistency"))
            print(f"- {name}, {r0['n']:,} -> {r1['n']:,}: " + ", ".join(parts))
    if "previous" in results:
        print("\nLargest relative difference current vs previous:")
        for r_new, r_old in zip(results["current"], results["previous"], strict=True):
            d = {k: float(np.max(np.abs(np.subtract(r_new[k], r_old[k]))
                                 / np.abs(np.asarray(r_old[k]))))
                 for k in ("mse", "loo_mse")}
            if "gains" in r_old:
                d["gains"] = float(np.max(np.abs(np.subtract(r_new["gains"], r_old["gains"]))
                                          / np.abs(np.asarray(r_old["gains"]))))
            print(f"- {r_new['n']:,}: " + ", ".join(f"{k} {v:.1e}" for k, v in d.items()))


if __name__ == "__main__":
    main()
